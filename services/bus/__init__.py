"""The Zenoh bus: key expressions and schemas (:mod:`.keys`), sessions (:mod:`.session`), clients
(:mod:`.control`)."""

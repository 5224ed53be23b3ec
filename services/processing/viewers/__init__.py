"""A processed trial's files for the lab's viewers: the results MCAP for Foxglove (:mod:`.results_mcap`),
the Rerun recording (:mod:`.rerun_trial`) and the Foxglove layout that opens both MCAPs
(:mod:`.foxglove_layout`). Their common input is a :class:`.trial_view.TrialView`."""

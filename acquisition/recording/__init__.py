"""One MCAP file per trial: writer (:mod:`.writer`), reader and crash recovery (:mod:`.reader`).

The file layout (topics, encodings, metadata records) is documented in :mod:`.layout`.
"""

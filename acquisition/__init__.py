"""Camera drivers, synchronisation, encoding, detectors and recording; calibration boards in images
(:mod:`.boards`) and other tools' files (:mod:`.importers`). The synthetic world is `gaitcap.simulator`."""

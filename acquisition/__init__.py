"""Camera drivers, synchronisation, encoding, detectors and recording (the synthetic world is `gaitcap.simulator`)."""

"""Camera drivers, synchronisation, encoding, detectors, recording, and the synthetic world."""

"""Trial processing: the worker, its computation, a trial's files, patient choice, calibration jobs."""

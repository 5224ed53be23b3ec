"""Research use: batch reprocessing, method specs, sweeps and where batch tasks run."""

"""Calibration boards in camera images: the board's description and file (:mod:`.file`), corner detection
(:mod:`.detection`), what a camera saw of it (:mod:`.diagnosis`), pairing the cameras' views
(:mod:`.pairing`), and board recordings read from MCAPs, folders and videos (:mod:`.recording`,
:mod:`.sources`)."""

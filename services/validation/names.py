"""Where a clinic trial's validation lives: ``<data_dir>/trials/<trial_id>/validation/`` with the files of
``gaitcap validate`` (``FILES``). No imports, so the API can read them without reaching the processing path."""

TRIAL_FOLDER = "validation"
FILES = {"json": "validation.json", "csv": "validation.csv", "bland_altman": "bland_altman.png",
         "angles": "angles.png", "pdf": "validation.pdf"}

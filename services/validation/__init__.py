"""``gaitcap validate`` and ``gaitcap validate-study``: a trial's agreement with a lab's reference.

``trial_data`` reads what gaitcap wrote for a trial (a ``gaitcap process`` output folder or a clinic
trial folder); ``compare`` aligns it with a reference (``gaitcap.acquisition.references``) and computes
the events, parameters and angles (``gaitcap.reconstruction.validation``); ``statistics`` gives the
agreement statistics (pingouin); ``files`` writes the JSON, CSV, plots and the PDF report; ``study`` runs
many pairs on the research executors and gives the study table.
"""

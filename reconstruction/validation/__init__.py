"""Agreement of a gaitcap trial with a lab's reference recording of the same walk (pure maths).

``reference``: the reference's contents (markers mapped to gaitcap joints, events, model angles, walkway
footfalls); ``align``: the time lag and the rigid transform, found from the data; ``events``: matched
heel strikes and toe offs; ``steps``: per-step parameter pairs and the trial-level ones; ``angles``: joint
angle curves against the reference model's. The readers are ``gaitcap.acquisition.references``; the
statistics, files and plots ``gaitcap.services.validation``.
"""

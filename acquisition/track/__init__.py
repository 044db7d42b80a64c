"""Following the drone from the operator's click: the object clicked, its motion, confusers,
occlusion, loss and reacquisition (tracker.py; config, candidate, reacquire, search, motion)."""

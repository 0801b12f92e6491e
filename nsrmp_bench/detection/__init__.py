"""Detected objects: the detections file, the classical depth-and-colour detector, and
detection metrics. Torch-free: the learned detector is ``reference_model/detector``."""

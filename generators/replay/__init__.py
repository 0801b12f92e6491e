"""Replaying a predictions file with the Panda: what the robot achieves when it carries out a
prediction, written as a prediction the ordinary scorer reads (``nsrmp-bench replay``).

Modules (import them by name; this package imports nothing heavy on its own):

* :mod:`.plan`: from a prediction (program, positions or boxes) to the moves to make;
* :mod:`.episode`: :func:`~.episode.replay_episode`, one episode carried out and measured;
* :mod:`.batch`: many episodes, in this process or a pool of workers, in task order.
"""

"""The Panda carries out steps by pick-and-place in the PyBullet world.

Modules (import them by name; this package imports nothing heavy on its own):

* :mod:`.pick_and_place`: :func:`~.pick_and_place.execute_step` and
  :func:`~.pick_and_place.execute_program`, one pick-and-place per step with its checks;
* :mod:`.realise`: :class:`~.realise.RobotPlacer`, the placer that has the Panda carry out
  each step when :func:`nsrmp_bench.generators.world.realise.realise` realises an episode;
* :mod:`.control`: the robot session (finger gear, friction, physics profile) and the arm
  controller (joint-space and straight Cartesian moves);
* :mod:`.kinematics`: forward and inverse kinematics of the arm in numpy;
* :mod:`.grasp`: grasp geometry of the parallel gripper (where to hold, hand yaw, heights);
* :mod:`.profiles`: the registered motion profiles (``fast``, ``realistic``);
* :mod:`.recorder`: recording joint trajectories at a fixed rate;
* :mod:`.path`: drawing a recorded end-effector path over an image.
"""

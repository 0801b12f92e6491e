"""The original authors' generator (``dair-iitd/nsrmp`` at a pinned commit), run unchanged
through a headless shim, and its output imported as an ordinary TEST part.

* :mod:`.tree`: the source tree (layout, pinned blob ids, needed modules);
* :mod:`.shim`: the child process that patches PyBullet and runs ``construct.py``;
* :mod:`.run`: one ``construct.py`` run into a folder;
* :mod:`.part`: the plan of runs and the import, with the manifest's pins.

Data made here is for reporting only: nothing trains or selects on it.
"""

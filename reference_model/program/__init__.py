"""Program parts shared by the program models (NSRM v2 and NMN+ v2).

- :mod:`.scene3d`: each object's 3D state from the inputs (box, depth, camera) and the
  analytic action rule that moves it (back-project, place, project), with its fitted
  corrections;
- :mod:`.consistent`: which grounded programs explain a training episode's final boxes
  (the box-derived training signal);
- :mod:`.splitter`: where an instruction breaks into steps;
- :mod:`.training`: the marginal likelihood over splits and consistent programs, which
  trains any step model;
- :mod:`.inference`: split, then run step after step on the state the previous steps left.

Nothing here reads a gold program, a lexed form, a template id or a reference label.
"""

"""The stages of a run as plain functions ``(case, model, ...) -> plain data``, called in order by
:mod:`fem2tmm.pipeline`: one module per stage (:mod:`.cluster`, :mod:`.quadrics`, :mod:`.radiation`, :mod:`.solar`,
:mod:`.orbit`, :mod:`.transient`, :mod:`.refine`).

Each function adapts a stage package (clustering, radiation, solar, quadrics, steady and transient solves) to the
case: it reads the case's settings and the FE model and returns arrays or the stage's own result type.  A new stage
is one more module here and one more call in :func:`fem2tmm.pipeline._run`.  The reduction methods
(:mod:`fem2tmm.reductors`) never import this package: they stand on the domain modules below it.
"""

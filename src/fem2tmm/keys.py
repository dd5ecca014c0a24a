"""The stage cache's keys (:mod:`fem2tmm.cache`): one digest per stage of exactly what the stage reads."""

from __future__ import annotations

import dataclasses

import numpy as np

from .cache import digest
from .case import Case
from .fem.model import FEModel
from .reduce.network import kept_dofs


# ------------------------------------------------------------------------------------------- cache keys
# Each key is a digest of exactly what the stage reads (fem2tmm.cache): its arrays as the stage receives them and
# its settings, so a case-file key that changes none of them keeps the cached result, and any change that does
# (including keys added to the case file or fields added to the model later) changes the key.
#: FEModel fields that :func:`~fem2tmm.reduce.network.refresh_reduced` applies per case (not in the reduce key)
_CASE_VALUES = {"Q", "loads", "T_sink", "fixed", "faces", "mesh"}
#: face fields that are optics: per case (``refresh_reduced``: g_space, area)
_FACE_OPTICS = {"emissivity", "absorptivity", "specular", "transmissivity", "transmission_specular", "active"}


def geometry_key(model: FEModel) -> str:
    """Digest of the radiating geometry: points, faces, the face -> element map and nodal weights."""
    f = model.faces
    return digest("geometry", model.mesh.points, f.nodes, f.element, f.W, model.mesh.n_elements)


def network_group(case: Case) -> str:
    """Key of the reduced network a load case can share with the other cases of its set: everything but what a
    case may change and still hand over the same GL, GR and C (boundary values, sink, Sun and orbit loads,
    transient, reference, name).  Cases that change the mesh, materials, optics, parts, joints, which nodes are
    held or loaded (the boundaries' kinds, groups and nodes), or the radiation, reduction and clustering
    settings get their own network."""
    bounds = tuple((b.kind, b.groups, b.nodes, b.name) for b in case.boundaries)
    return digest("network", repr(case.mesh), sorted((k, repr(v)) for k, v in case.materials.items()),
                  sorted((k, repr(v)) for k, v in case.optics.items()), repr(case.parts), repr(case.joints), bounds,
                  repr(case.radiation), repr(_network_settings(case.reduction)), repr(case.clustering))


def reduce_key(model: FEModel, case: Case, clustering_key: str, T_ref: np.ndarray | None = None) -> str:
    """Key of :func:`~fem2tmm.reduce.network.build_reduced` up to what
    :func:`~fem2tmm.reduce.network.refresh_reduced` applies per case (loads, boundary temperatures, sink,
    optics): the clustering and every other field of the FE model, the fixed groups' nodes, the kept nodes
    and the ``[reduction]`` settings; for a radiation-aware reduction (``T_ref``) also T_ref, the faces' εA and
    the sink, which its operator holds."""
    fields = {f.name: getattr(model, f.name) for f in dataclasses.fields(model) if f.name not in _CASE_VALUES}
    faces = {f.name: getattr(model.faces, f.name) for f in dataclasses.fields(model.faces)
             if f.name not in _FACE_OPTICS}
    fixed = [(g.name, g.dof, g.nodes) for g in model.fixed]
    aware = None if T_ref is None else (T_ref, model.faces.eps_area, model.T_sink)
    return digest("reduce", clustering_key, fields, faces, fixed, model.mesh.node_ids, kept_dofs(model, case),
                  _network_settings(case.reduction), aware)


def _network_settings(reduction):
    """The ``[reduction]`` settings that make the network: without ``verify`` (the validity check after it)."""
    return dataclasses.replace(reduction, verify=True, verify_range=())


def scene_key(fit: tuple | None) -> str:
    """Digest of the ray scene's shape: flat triangles (``fit`` None) or the fitted quadrics ``(quadrics,
    quadric_of_face, report)`` of :func:`fit_quadrics`."""
    return "flat" if fit is None else digest("quadrics", list(fit[0]), fit[1])


def trace_key(stage: str, geometry: str, optics, scene: str, *settings) -> str:
    """Key of a ray-tracing stage: the geometry (:func:`geometry_key`), the band's per-side optics (a
    :class:`~fem2tmm.radiation.surfaces.SideOptics`), the scene (:func:`scene_key`) and the stage's settings."""
    return digest(stage, geometry, optics, scene, *settings)

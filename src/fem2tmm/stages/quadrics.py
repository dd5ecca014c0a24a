"""The quadric scene: the case's curved regions fitted by quadrics for the ray tracer.
"""

from __future__ import annotations

import numpy as np

from ..case import Case
from ..cluster import Clustering
from ..fem.model import FEModel
from ..radiation import Surface
from ..radiation.quadric import fit_regions
from ..radiation.quadric_scene import QuadricScene


# --------------------------------------------------------------------------------------------- quadrics
def quadric_scene(model: FEModel, case: Case, surface: Surface, clustering: Clustering | None = None):
    """The ray scene with fitted quadrics for the parts tagged ``quadric = true`` (or the groups listed in
    ``quadric = [...]``), or None.

    One quadric is fitted per region of the tagged faces (regions: the clustering's, i.e. split at sharp edges
    and junctions, restricted to the tagged groups; without a clustering, one per part).  A region that is not a quadric is refused with a
    clear error (see :func:`fem2tmm.radiation.quadric.fit_quadric`).  Returns ``(scene, report)``.
    """
    if not any(p.quadric for p in case.parts):
        return None, None
    quadrics, qof, report = fit_quadrics(*quadric_regions(model, case, clustering))
    return QuadricScene(surface, qof, quadrics), report


def quadric_regions(model: FEModel, case: Case, clustering: Clustering | None = None):
    """What the quadric fits depend on: ``(points (n, 3), faces (f, 4), region_of_face (f,) int (-1: flat),
    names {region: label})`` (see :func:`quadric_scene`)."""
    f = model.faces
    mesh = model.mesh
    tagged_el = np.zeros(mesh.n_elements, bool)
    for p, info in zip(case.parts, model.parts):
        if p.quadric is True:
            tagged_el[info.elements] = True
        elif p.quadric:
            for g in p.quadric:
                tagged_el[np.intersect1d(mesh.group(g).elements, info.elements)] = True
    in_tagged = tagged_el[f.element]
    if clustering is not None:
        region = clustering.regions[f.element]
        region_of_face = np.where(in_tagged & (region >= 0), region, -1)
        # determined elements carry no cluster/region: give them their part's id beyond the region ids
        rest = in_tagged & (region < 0)
        region_of_face[rest] = int(clustering.regions.max(initial=-1)) + 1 + f.part[rest]
    else:
        region_of_face = np.where(in_tagged, f.part, -1)
    names = {}
    for r in np.unique(region_of_face[region_of_face >= 0]):
        part = case.parts[int(f.part[np.flatnonzero(region_of_face == r)[0]])].name
        names[int(r)] = f"part {part!r} region {int(r)}"
    return model.mesh.points, f.nodes, region_of_face, names


def fit_quadrics(points, faces, region_of_face, names):
    """``(quadrics, quadric_of_face, report)``: one fitted quadric per region (:func:`quadric_regions`) and the
    fit report of each (summary.json "quadrics")."""
    quadrics, qof = fit_regions(points, faces, region_of_face, names=names)
    report = [{"region": names[int(r)], "max_distance_m": float(q.max_distance), "rms_distance_m": float(q.rms_distance),
               "size_m": float(q.size)} for r, q in zip(sorted(names), quadrics)]
    return quadrics, qof, report

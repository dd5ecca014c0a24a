"""Solar-aware clustering (PartInput.flux): clusters follow shadow lines, half-lit regions get more clusters.

Independent references: the shadow line is a closed-form position on a structured grid (the flux map is a step),
and the exact reduction gives zero lumping error exactly when the flux is uniform on every cluster
(X Aᵀ = 0, DESIGN §3.2), so "each cluster's flux is uniform" is the property that matters, checked by brute force.
"""

import numpy as np
import pytest

from fem2tmm import Case, Fem2TmmError
from fem2tmm.cluster import PartInput, cluster_parts
from fem2tmm.mesh.elements import TYPE_CODE


def strip(profile, ny, width=1.0):
    """Quads on a (x, z) polyline profile swept along y: points (n, 3), cells (m, 4), element centroids (m, 3)."""
    prof = np.asarray(profile, float)
    y = np.linspace(0, width, ny + 1)
    P = np.array([[x, yy, z] for yy in y for x, z in prof])
    nu = len(prof)
    i, j = np.meshgrid(np.arange(nu - 1), np.arange(ny), indexing="ij")
    a = (j * nu + i).ravel()
    cells = np.stack([a, a + 1, a + 1 + nu, a + nu], 1)
    return P, cells, P[cells].mean(1)


def part(cells, n, flux=None):
    m = len(cells)
    padded = np.full((m, 8), -1, np.int64)
    padded[:, :4] = cells
    return PartInput(name="p", kind="shell", elements=np.arange(m), cells=padded,
                     types=np.full(m, TYPE_CODE["quad4"], np.int8), n_clusters=n, flux=flux)


def within_cluster_flux_spread(labels, flux):
    return max(np.ptp(flux[labels == c]) for c in np.unique(labels))


def test_two_clusters_split_along_the_shadow_line():
    # flat 1 x 1 plate, 20 x 20 quads, lit (1000 W/m²) for x < 0.3 and in shadow beyond
    P, cells, cen = strip([(x, 0.0) for x in np.linspace(0, 1, 21)], 20)
    flux = np.where(cen[:, 0] < 0.3, 1000.0, 0.0)
    geo = cluster_parts(P, [part(cells, 2)], len(cells)).labels
    lab = cluster_parts(P, [part(cells, 2, flux)], len(cells)).labels
    # without the flux map k-means halves the square: some cluster straddles the shadow line (the test can fail)
    assert within_cluster_flux_spread(geo, flux) == 1000.0
    # with it, the boundary is the shadow line x = 0.3 exactly (closed form on this grid): uniform flux per cluster
    assert within_cluster_flux_spread(lab, flux) == 0.0
    assert len(np.unique(lab[cen[:, 0] < 0.3])) == 1 and len(np.unique(lab)) == 2


def test_half_lit_region_gets_the_extra_cluster():
    # a plate folded at 90 degrees (two regions): A, 1.5 x 1, uniformly lit; B, 1 x 1, lit on its lower half only
    prof = [(x, 0.0) for x in np.linspace(0, 1.5, 16)] + [(1.5, z) for z in np.linspace(0.1, 1.0, 10)]
    P, cells, cen = strip(prof, 10)
    in_B = cen[:, 0] > 1.5 - 1e-9
    flux = np.where(in_B & (cen[:, 2] > 0.5), 0.0, 800.0)
    geo = cluster_parts(P, [part(cells, 3)], len(cells))
    res = cluster_parts(P, [part(cells, 3, flux)], len(cells))
    n_in = lambda r, sel: len(np.unique(r.labels[sel]))  # noqa: E731
    # by area alone A (1.5 m²) takes 2 clusters and B (1 m²) 1, which lumps B's lit and dark halves together
    assert (n_in(geo, ~in_B), n_in(geo, in_B)) == (2, 1)
    assert within_cluster_flux_spread(geo.labels, flux) == 800.0
    # flux-driven weights A_r (1 + σ_r/σ), flux in units of 800 W/m²: part mean 0.8, σ = 0.4, σ_A = 0, σ_B = 0.5,
    # so A 1.5·1 = 1.5 against B 1·(1 + 0.5/0.4) = 2.25 -> B gets 2 clusters, split at its shadow line z = 0.5
    assert (n_in(res, ~in_B), n_in(res, in_B)) == (1, 2)
    assert within_cluster_flux_spread(res.labels, flux) == 0.0


def test_uniform_flux_changes_nothing():
    # a uniform flux carries no information: same clusters as without it (identical labels, same seed)
    P, cells, cen = strip([(x, 0.0) for x in np.linspace(0, 1, 21)], 20)
    a = cluster_parts(P, [part(cells, 5)], len(cells)).labels
    b = cluster_parts(P, [part(cells, 5, np.full(len(cells), 300.0))], len(cells)).labels
    assert np.array_equal(a, b)


def _case(tmp_path, clustering="", solar_on="super_faces"):
    text = f"""
[mesh]
file = "m.msh"
[materials.al]
conductivity = 170.0
[[parts]]
name = "p"
groups = ["g"]
material = "al"
thickness = 0.001
super_nodes = 2
[environment]
sun_direction = [0.0, 0.0, 1.0]
solar_flux = 1000.0
solar_on = "{solar_on}"
[clustering]
{clustering}
"""
    f = tmp_path / "case.toml"
    f.write_text(text)
    return Case.from_toml(f)


def test_case_option(tmp_path):
    assert _case(tmp_path).solar_aware is True  # default: on with super-face solar loads
    assert _case(tmp_path, solar_on="detailed").solar_aware is False  # exact distribution: nothing to follow
    assert _case(tmp_path, "solar_aware = false").solar_aware is False
    assert _case(tmp_path, "solar_aware = true", solar_on="detailed").solar_aware is True
    with pytest.raises(Fem2TmmError, match="solar_aware"):
        _case(tmp_path, 'solar_aware = "yes"')

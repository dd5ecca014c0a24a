"""The TOML case file -> validated frozen dataclasses.  The only place that knows the schema.

Temperatures are °C in the file and Kelvin in the dataclasses; lengths in metres except ``[mesh] unit``
which is the length unit of the mesh file.  Every error names the file, the key and what was expected.
Unknown keys are errors (a typo must not silently change a model).  :func:`load` (or :meth:`Case.from_toml`)
reads a file; the package is split by table: :mod:`.types` (the sections' dataclasses), :mod:`.load` (the
:class:`Case`, the parser's shared checks and the top level, the load cases of a set), :mod:`.model_tables`,
:mod:`.environment_tables`, :mod:`.settings_tables` (each table's reader).

See DESIGN §4.2 for an annotated example.
"""

from .load import Case, load, load_cases
from .settings_tables import check_scheduler
from .types import (Boundary, BoundaryKind, CapacitanceMethod, ClusteringAllocation, ClusteringMethod,
                    ClusteringSettings, ComputeSettings, Environment, ExportSettings, JOINT_CARDS, JOINT_TREATMENTS,
                    Joint, JointTreatment, MIN_EMISSIVITY, Material, MeshSpec, NONE_OPTICS, Optics, OrbitSettings, Part,
                    RadiationSettings, ReducedNetwork, ReductionMethod, ReductionSettings, ReferenceSettings, Sampling,
                    SolarOn, SolverSettings, TRANSIENT_METHODS, TransientCapacitance, TransientMethod, TransientSpec)

__all__ = ["Boundary", "BoundaryKind", "CapacitanceMethod", "Case", "ClusteringAllocation", "ClusteringMethod",
           "ClusteringSettings", "ComputeSettings", "Environment", "ExportSettings", "JOINT_CARDS", "JOINT_TREATMENTS",
           "Joint", "JointTreatment", "MIN_EMISSIVITY", "Material", "MeshSpec", "NONE_OPTICS", "Optics",
           "OrbitSettings", "Part", "RadiationSettings", "ReducedNetwork", "ReductionMethod", "ReductionSettings",
           "ReferenceSettings", "Sampling", "SolarOn", "SolverSettings", "TRANSIENT_METHODS", "TransientCapacitance",
           "TransientMethod", "TransientSpec", "check_scheduler", "load", "load_cases"]

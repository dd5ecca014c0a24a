"""Nastran bulk data reader (in-house, vectorised).

:func:`read_nastran` turns a Nastran bulk data deck (``.bdf``, ``.nas``, ``.dat``) into a
:class:`fem2tmm.mesh.Mesh`.

Cards read
----------
Every card is either modelled, read as a thermal joint or load, listed as ignored (non-structural: PARAM,
loads, SEQGP, CONM2, ...: one warning, ``Mesh.cards["ignored"]``, summary.json ``mesh.ignored_cards``), or
refused: a structural card fem2tmm does not model (RBAR, RBE1, MPC, CELAS3, CQUADX, any other element card)
stops the read with one error listing each card and its count and naming ``[mesh] ignore_cards``.

=============================  ======================================================================
GRID                           ID, CP, X1-X3 (CP: coordinate system of the position; CD, PS, SEID ignored)
GRDSET                         default CP (and CD, ignored) for GRIDs whose CP field is blank
CORD2R, CORD2C, CORD2S         rectangular, cylindrical (r, theta deg, z), spherical (r, theta deg, phi deg)
                               systems given by three points A, B, C in a reference system RID; RID chains
                               of any depth and in any order in the file; blank coordinates are 0.0
CTRIA3 CTRIAR, CQUAD4 CQUADR   -> ``tri3``, ``quad4`` (THETA/MCID, ZOFFS, TFLAG, T1-T4 ignored; blank PID = EID)
CTRIA6, CQUAD8                 -> ``tri3``, ``quad4`` on the corner GRIDs; the mid-side GRIDs are not solved for:
                               ``Mesh.midside`` rows (node, a, b), their temperature is the mean of the edge
                               ends in the outputs (one warning; curved edges are straightened)
CSHEAR, NASTRAN-95 CQUAD1/2,   -> ``quad4`` / ``tri3`` with their property cards PSHEAR, PQUAD1/2, PQDMEM(1/2),
CQDMEM(1/2), CTRIA1/2, CTRMEM  PTRIA1/2, PTRMEM (PID, MID, T like PSHELL)
CTETRA, CHEXA, CPENTA          -> ``tet4``, ``hex8``, ``wedge6``; 10/20/15-node variants on their corners as above
CHEXA1, CHEXA2, CWEDGE         NASTRAN-95 solids -> ``hex8``, ``wedge6``: field 2 is a material id (no PSOLID);
                               a solid PID with no PSOLID whose id is a material's is read the same way
CBAR, CBEAM, CROD, CTUBE,      -> ``line2`` (conduction along the axis); areas from PBAR A, PBEAM A(A), PROD A,
CONROD                         PTUBE (OD, T), CONROD A, PBARL/PBEAML sections ROD, TUBE, TUBE2, BAR, BOX, I,
                               CHAN, T, L, H (MSC QRG areas; other section types refused by name);
                               ``Mesh.section_area``; CONROD groups ``"CONROD MID m"``
RBE2, RBE3, CBUSH, CELAS1,     thermal joints (``Mesh.joints``: one connection per independent/dependent GRID
CELAS2, CGAP                   pair, GA-GB for springs; grounded springs connect nothing); the case decides
                               their treatment (``[[joints]]``)
PSHELL, PSOLID                 PID, MID1 (the membrane material, the one heat transfer uses), T / PID, MID
PCOMP, PCOMPG                  thickness = sum of the plies (LAM = SYM doubles them); conductivity, density and
                               specific heat averaged over the plies by thickness (in-plane plies in parallel)
MAT4, MAT5                     K, CP, RHO; MAT5: the tensor KXX..KZZ (basic system), CP, RHO
MAT1, MAT8                     RHO only (MAT4/MAT5 values win)
SPC, SPC1, TEMP, TEMPD, QBDY*, with ``loads`` (``[mesh] nastran_loads``): see :mod:`fem2tmm.io.nastran.loads`
QHBDY, QVOL, CHBDY*, RADBC,
RADM, PHBDY
=============================  ======================================================================

Formats
-------
Small field (8-character fields), large field (``GRID*``: 16-character fields, two physical lines per
eight data fields), free field (commas; ``GRID*,`` is large free field, four data fields per line) and any
mix of them within a deck or a card.  A continuation line starts with ``+`` (small field), ``*`` (large
field) or a blank first field; a blank first field continues in the width of the line before it.  The
markers in field 10 / field 1 are not matched: continuation lines must follow their parent, as modern
Nastran requires.  Tabs expand to 8-column stops.  ``$`` starts a comment anywhere on a line.  Real
numbers may use ``E`` or ``D`` exponents, Nastran's implicit exponent (``1.-3``, ``-.5+2``) and embedded
blanks (``.2523 -3``); integers are accepted in real fields.  Free- and small-field replication: a card whose
first field is ``=`` repeats the card before it, field by field: ``=`` copies the field, ``==`` copies all the
remaining fields, ``*x`` / ``*(x)`` adds x; ``=n`` / ``=(n)`` repeats the last replication n times.  Only the
cards the model uses are parsed strictly: a malformed field in a property or material card no element uses is
one warning naming file:line.  ``INCLUDE 'file'`` (quoted, possibly over several lines, or bare) is searched
relative to the including file, then the top deck's folder, then the working directory (a missing file names
every place tried), recursively; an include cycle is an error.  When the top file
has a ``BEGIN BULK`` line, everything before it (executive and case control) is skipped; reading stops
at ``ENDDATA``.  Decks without either are read whole.  Columns past 72 of a fixed-format line (field
10) are ignored; a free-field line holds at most 8 data fields (4 in large free field) plus a marker.

Units
-----
Point coordinates are multiplied by metres per deck length unit.  Property data goes into
``Mesh.properties["PID <n>"]`` as :class:`~fem2tmm.mesh.PropertyData` in SI units, converted from the deck's
unit system (``unit_system``, :data:`fem2tmm.io.units.UNIT_SYSTEMS`: m-kg-s, mm-t-s, mm-kg-s, mm-kg-ms,
cm-g-s, in-lbf-s, ft-lbf-s; per-degree values with ``temperature_unit`` K/C/F/R).  Without ``unit_system``,
length unit ``m`` means SI and ``mm`` the mm-tonne-s system; any other unit leaves the material values
``None`` with a warning (the case must give them or declare the unit system); the lbf systems without a
temperature unit are refused as ambiguous.  A blank K, CP or RHO gives ``None`` (Nastran's MAT4 default
RHO = 1.0 is deliberately not applied), and so does a material id that no material card defines (warning).

Output
------
Points are kept in file order (GRIDs that no element uses are kept; the model builder ignores them),
``Mesh.node_ids`` holds the GRID ids, each block's ``ids`` the element ids, blocks follow
:data:`fem2tmm.mesh.elements.ELEMENT_TYPES` order with elements in file order.  Each property id becomes a
group ``"PID <n>"`` (dim 1 for bars, 2 for shells, 3 for solids) with its elements and their nodes.

Implementation: one pass over the lines does only classification and slicing (a fixed-format card is
kept as the raw bytes of its data columns); every field of every card is then converted with numpy on
(n, width) byte arrays, and coordinate systems are applied vectorised per system.
"""

from .reader import read_nastran

__all__ = ["read_nastran"]

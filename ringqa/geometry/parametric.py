"""Parametric ring applicators modelled on the Elekta/Nucletron Ring CT/MR sets.

Frame (metres): ring centre at the origin, ring plane z = 0, ``ring_normal`` = +z (cranial),
``ring_lateral`` = +x (patient left), +y posterior (DICOM patient axes), so anterior is -y.

Ring channel centreline, proximal -> distal:

1. a straight STEM (the paper's "plastic tube insert", default 60 mm) coming from caudal/anterior:
   its distal direction is ``(0, cos a, sin a)``, ``a`` = stem-to-ring-plane angle (45 or 60 deg);
2. a TRANSITION (default 28 mm of arc, domain.md) from the stem to the circle: a quintic Hermite
   curve that matches position, tangent and curvature vector at both ends (curvature 0 on the stem
   side, 1/R towards the centre on the ring side), so the curvature is continuous (G2). It starts
   at ``B + c (11 in_B - 20 t_B - 12 z)`` mm (``in_B`` inwards, ``t_B`` the circle tangent at the
   join B), offsets read off the Oncentra 26/60 library centreline, with ``c`` solved so the
   transition is ``transition_mm`` long (c ~ 1). Like the Oncentra channel it is an S-shaped bend
   (curvature ~0.09, dip ~0.05, ~0.085 1/mm on the 26 mm ring; the library's: 0.074, 0.022,
   0.086 1/mm) with smooth torsion (< 0.3 1/mm);
3. the CIRCLE of radius R = diameter / 2 in the ring plane, run counter-clockwise seen from cranial
   (from the patient's left side towards posterior) from the join at +1.5 deg azimuth (from +x;
   fitted to the Oncentra library, see below) for ``run_deg`` (default 264 deg, the 26 mm
   Oncentra ring, domain.md) to the lumen tip at 265.5 deg (anterior, slightly right). The same
   ANGULAR run is kept for every size (the arc grows with R: 59.9 / 69.1 / 78.3 mm for 26 / 30 /
   34 mm) so that every ring covers both lateral sides; the gap is the anterior-left quadrant
   where the stem enters.

With these choices the 26/60 channel reproduces the Oncentra library's centreline (the shared
plan; frame: its ring centre and normal, lateral = DICOM +x projected into the ring plane), at
equal distance from the lumen tip, within 0.03 mm on the circle, 1.0 mm over the transition and
1.1 mm along the first 30 mm of stem (tests/io/test_io_applicator_file.py). domain.md's "join at
about -4 deg" is where the library's transition still runs 0.1 mm outside the circle; the circle
proper starts at +1.5 deg. The stem passes 7-11 mm from the distal ring (the near-branch case of
the closest-point search).

Lumen: 3.0 mm (r_b 1.5 mm, paper's r_a 1.4 mm), U-shaped from the start of the transition to the
tip, its flat side facing the outside of the ring (fixed in the applicator's frame, as a moulded
groove is) and lying at the 1.5 mm circle (:data:`FLAT_MM`): the paper reports the source about
1.1 mm off the centreline against the flat, 1.5 mm in theory (section 3.1), i.e. a flat at or beyond
the circle, which then does not cut the circular cross-section (the source centre reaches
1.5 - 0.425 = 1.075 mm); circular along the straight stem. :data:`LUMEN_SOURCE` is printed with
it. (Until issue 13 the flat was ASSUMED 1.2 mm and followed the Frenet normal:
docs/commissioning.md shows what the choice moves.) ``s_ref`` = lumen tip minus 5.0 mm
(the "1st marker" offset of the Oncentra library, domain.md).

Tandem: straight, along the ring normal through the ring centre (lumen 2.5 mm, r_a = r_b - 0.1
mm, ASSUMED), from ``stem_mm`` below the ring plane to ``length_mm`` above it; s_ref = tip minus
5.0 mm (ASSUMED the same convention as the ring).
"""

from __future__ import annotations

import numpy as np

from ringqa.geometry.applicator import Applicator, Channel
from ringqa.geometry.centreline import Centreline, GeometryError
from ringqa.geometry.lumen import FlatSide, Lumen
from ringqa.units import deg_to_rad, mm_to_m

#: Defaults (mm / deg) and their sources.
STEM_MM = 60.0
TRANSITION_MM = 28.0
RUN_DEG = 264.0
JOIN_AZIMUTH_DEG = 1.5
#: Start of the transition relative to the join point B, in B's frame (inwards, back along the
#: tangent, caudally), mm: read off the Oncentra 26/60 library centreline; scaled per ring so the
#: transition is TRANSITION_MM long.
TRANSITION_OFFSETS_MM = (11.0, 20.0, 12.0)
RING_LUMEN_DIAMETER_MM = 3.0
RING_R_A_MM = 1.4
#: the U-shaped ring lumen's flat side from the centreline (mm): at the 1.5 mm circle (the paper)
FLAT_MM = 1.5
#: where the ring lumen's dimensions come from (printed in reports)
LUMEN_SOURCE = (
    "3.0 mm, r_a 1.4 mm and the U shape: Straathof et al., Med Phys 2024 (Table 1, section 3.1: "
    "the source reaches about 1.1 mm off the centreline against the flat side, 1.5 mm in theory, "
    "so the flat lies at or beyond the 1.5 mm circle: modelled at the circle, facing the outside "
    "of the ring); circular along the 60 mm stem insert"
)
TIP_TO_FIRST_DWELL_MM = 5.0
TANDEM_LUMEN_DIAMETER_MM = 2.5
TANDEM_LENGTH_MM = 60.0
TANDEM_STEM_MM = 60.0
POINT_SPACING_MM = 0.5

SOURCES = (
    "Ring sizes 26/30/34 mm = source-to-source (channel centreline) diameter: GEC-ESTRO Handbook "
    "of Brachytherapy; 26 mm confirmed as a 13.0 mm circle in the Oncentra applicator library "
    "(shared/reference/rtplans/oncentra_ring26x60).",
    "Transition ~28 mm, circle run 264 deg (60 mm) to the lumen tip, 1st marker 5.0 mm from the "
    "tip: Oncentra 4.3 library 'Interstitial Ring CT/MR d=26mm, 60 deg' (domain.md).",
    "Lumen 3.0 mm, r_a = 1.4 mm, U-shaped ring lumen, 60 mm plastic stem insert: Straathof et "
    "al., Med Phys 2024. Tandem lumen 2.5 mm: Oncentra library.",
)

ASSUMPTIONS = (
    "Flat side of the U-shaped lumen at the 1.5 mm circle, facing the outside of the ring (the "
    "paper: about 1.1 mm reached, 1.5 mm in theory; the exact distance beyond the circle is not "
    "given and does not change what the source can reach); circular along the straight stem.",
    "Same angular run (264 deg) from the same join azimuth (+1.5 deg) for every ring size; "
    "transition 28 mm with the Oncentra 26/60 start offsets (11, 20, 12) mm for every size.",
    "Stem distal direction (0, cos a, sin a): comes from caudal/anterior in a sagittal plane "
    "(as in the Oncentra 26/60 library, whose stem is at 60.0 deg to the ring plane).",
    "Tandem along the ring normal through the ring centre, 60 mm above and 60 mm below the ring "
    "plane, r_a = r_b - 0.1 mm, relative position 0 at 5.0 mm from its tip.",
)


def _hermite5(p0, v0, a0, p1, v1, a1, t):
    """Quintic Hermite curve at parameters ``t (k,)`` -> (k, 3)."""
    t = t[:, None]
    t2, t3 = t * t, t * t * t
    t4, t5 = t3 * t, t3 * t2
    h0 = 1 - 10 * t3 + 15 * t4 - 6 * t5
    h1 = t - 6 * t3 + 8 * t4 - 3 * t5
    h2 = 0.5 * t2 - 1.5 * t3 + 1.5 * t4 - 0.5 * t5
    h3 = 0.5 * t3 - t4 + 0.5 * t5
    h4 = -4 * t3 + 7 * t4 - 3 * t5
    h5 = 10 * t3 - 15 * t4 + 6 * t5
    return h0 * p0 + h1 * v0 + h2 * a0 + h3 * a1 + h4 * v1 + h5 * p1


def _polyline_length(p: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


def _transition(b, t_b, k_b, d, start, n_fine: int = 4001):
    """Quintic Hermite transition from ``start`` (tangent d, curvature 0) to the circle at ``b``
    (tangent t_b, curvature vector k_b).

    Returns (fine points (n_fine, 3), arc length). The Hermite speed parameter is iterated to the
    arc length so the curve is traversed at near-unit speed at both ends (then the end curvatures
    are exactly 0 and |k_b|).
    """
    ell = float(np.linalg.norm(b - start))
    t = np.linspace(0.0, 1.0, n_fine)
    for _ in range(40):
        pts = _hermite5(start, ell * d, np.zeros(3), b, ell * t_b, ell * ell * k_b, t)
        new = _polyline_length(pts)
        if abs(new - ell) < 1e-10 * new:
            break
        ell = new
    return pts, ell


def ring_centreline_mm(
    diameter_mm: float,
    angle_deg: float,
    stem_mm: float = STEM_MM,
    transition_mm: float = TRANSITION_MM,
    run_deg: float = RUN_DEG,
    join_azimuth_deg: float = JOIN_AZIMUTH_DEG,
    spacing_mm: float = POINT_SPACING_MM,
) -> tuple[np.ndarray, dict]:
    """Points (mm) of the parametric ring channel centreline, proximal -> distal.

    Returns
    -------
    points_mm : (n, 3) ndarray
    info : dict
        ``stem_mm``, ``transition_mm`` (achieved), ``circle_mm`` (arc of the circle part),
        ``join_azimuth_deg``, ``tip_azimuth_deg``, ``transition_start_mm`` (point where the stem
        ends), ``transition_scale`` (solved factor on the Oncentra-shaped offsets),
        ``stem_direction``.
    """
    r = float(diameter_mm) / 2.0
    alpha = float(deg_to_rad(angle_deg))
    if not (0.0 < alpha < np.pi / 2 + 1e-12):
        raise GeometryError(f"angle_deg: must be in (0, 90] degrees, got {angle_deg!r}")
    if not (5.0 <= r <= 50.0):
        raise GeometryError(f"diameter_mm: {diameter_mm!r} mm is not a ring size (10-100 mm)")
    if not (0.0 < run_deg < 350.0):
        raise GeometryError(f"run_deg: must be in (0, 350) degrees, got {run_deg!r}")
    if not (10.0 <= transition_mm <= 80.0):
        raise GeometryError(f"transition_mm: must be 10-80 mm, got {transition_mm!r}")
    phi_b = np.deg2rad(join_azimuth_deg)
    b = r * np.array([np.cos(phi_b), np.sin(phi_b), 0.0])
    t_b = np.array([-np.sin(phi_b), np.cos(phi_b), 0.0])
    in_b = -b / r
    k_b = in_b / r
    d = np.array([0.0, np.cos(alpha), np.sin(alpha)])
    off = np.asarray(TRANSITION_OFFSETS_MM)
    direction = off[0] * in_b - off[1] * t_b - off[2] * np.array([0.0, 0.0, 1.0])

    # scale the start offset so that the transition is transition_mm long (monotone: bisection)
    lo, hi = 0.1, 4.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        _, ell = _transition(b, t_b, k_b, d, b + mid * direction, 801)
        if ell < transition_mm:
            lo = mid
        else:
            hi = mid
    scale = 0.5 * (lo + hi)
    start = b + scale * direction
    fine, ell = _transition(b, t_b, k_b, d, start)

    # resample the transition at ~spacing by arc length (fine polyline)
    cum = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(fine, axis=0), axis=1))]
    n_tr = max(int(np.ceil(cum[-1] / spacing_mm)), 4)
    s_tr = np.linspace(0.0, cum[-1], n_tr + 1)
    trans = np.c_[[np.interp(s_tr, cum, fine[:, c]) for c in range(3)]].T

    n_stem = max(int(np.ceil(stem_mm / spacing_mm)), 2)
    u = np.linspace(-stem_mm, 0.0, n_stem + 1)[:-1]
    stem = start + u[:, None] * d

    arc = r * np.deg2rad(run_deg)
    n_arc = max(int(np.ceil(arc / spacing_mm)), 4)
    phi = phi_b + np.linspace(0.0, np.deg2rad(run_deg), n_arc + 1)[1:]
    circle = r * np.c_[np.cos(phi), np.sin(phi), np.zeros_like(phi)]
    pts = np.vstack([stem, trans, circle])
    info = {
        "stem_mm": float(stem_mm),
        "transition_mm": float(ell),
        "circle_mm": float(arc),
        "join_azimuth_deg": float(join_azimuth_deg),
        "tip_azimuth_deg": float(join_azimuth_deg + run_deg),
        "transition_start_mm": [float(v) for v in start],
        "transition_scale": float(scale),
        "stem_direction": [float(v) for v in d],
    }
    return pts, info


def tandem_channel(
    length_mm: float = TANDEM_LENGTH_MM,
    stem_mm: float = TANDEM_STEM_MM,
    lumen_diameter_mm: float = TANDEM_LUMEN_DIAMETER_MM,
    tip_to_first_dwell_mm: float = TIP_TO_FIRST_DWELL_MM,
    centre_m=(0.0, 0.0, 0.0),
    normal=(0.0, 0.0, 1.0),
    name: str = "tandem",
) -> Channel:
    """A straight tandem (intra-uterine tube) channel along ``normal`` through ``centre_m``.

    Parameters
    ----------
    length_mm : float
        Lumen tip height above the ring plane (mm).
    stem_mm : float
        Length of channel below the ring plane (mm).
    lumen_diameter_mm : float
        Lumen diameter (mm); r_a = r_b - 0.1 mm (assumed).
    tip_to_first_dwell_mm : float
        Lumen tip to relative position 0 (mm).
    centre_m : (3,) array_like
        Ring centre (m).
    normal : (3,) array_like
        Unit ring normal (cranial).
    """
    if not (length_mm > tip_to_first_dwell_mm >= 0.0 and stem_mm >= 0.0):
        raise GeometryError(
            "tandem_channel: need length_mm > tip_to_first_dwell_mm >= 0 and stem_mm >= 0"
        )
    n = np.asarray(normal, dtype=float)
    n = n / np.linalg.norm(n)
    total = stem_mm + length_mm
    k = max(int(np.ceil(total / 1.0)), 4)
    z = np.linspace(-stem_mm, length_mm, k + 1)
    pts = np.asarray(centre_m, dtype=float) + mm_to_m(z)[:, None] * n
    cl = Centreline.from_points(pts)
    rb = lumen_diameter_mm / 2.0
    circ = Lumen.circular(mm_to_m(rb), mm_to_m(rb - 0.1))
    lumen = Lumen(circ.seg_s, circ.seg_rb, circ.seg_ra, circ.seg_flat,
                  source="2.5 mm: Oncentra library; r_a = r_b - 0.1 mm assumed")  # fmt: skip
    return Channel(name, cl, lumen, cl.length_m - mm_to_m(tip_to_first_dwell_mm))


def ring_channel(
    diameter_mm: float,
    angle_deg: float,
    stem_mm: float = STEM_MM,
    transition_mm: float = TRANSITION_MM,
    run_deg: float = RUN_DEG,
    join_azimuth_deg: float = JOIN_AZIMUTH_DEG,
    flat_mm: float = FLAT_MM,
    tip_to_first_dwell_mm: float = TIP_TO_FIRST_DWELL_MM,
    name: str = "ring",
) -> tuple[Channel, dict]:
    """The parametric ring channel (see the module docstring) and its construction info."""
    pts_mm, info = ring_centreline_mm(
        diameter_mm, angle_deg, stem_mm, transition_mm, run_deg, join_azimuth_deg
    )
    cl = Centreline.from_points(mm_to_m(pts_mm))
    rb = RING_LUMEN_DIAMETER_MM / 2.0
    side = FlatSide("ring_outside", np.zeros(3), np.array([0.0, 0.0, 1.0]))
    lumen = Lumen.u_shaped(mm_to_m(rb), mm_to_m(RING_R_A_MM), mm_to_m(flat_mm), mm_to_m(stem_mm),
                           flat_side=side, source=LUMEN_SOURCE)  # fmt: skip
    ch = Channel(name, cl, lumen, cl.length_m - mm_to_m(tip_to_first_dwell_mm))
    return ch, info


def ring_applicator(diameter_mm: float, angle_deg: float, **kwargs) -> Applicator:
    """The parametric Elekta-like ring applicator ``ring<diameter>x<angle>`` (ring + tandem).

    Parameters
    ----------
    diameter_mm : float
        Source-to-source (channel centreline) diameter (26, 30, 34 mm).
    angle_deg : float
        Stem-to-ring-plane angle (45 or 60 degrees).
    **kwargs
        Optional overrides of :func:`ring_channel` (``stem_mm``, ``transition_mm``, ``run_deg``,
        ``join_azimuth_deg``, ``flat_mm``, ``tip_to_first_dwell_mm``).

    Returns
    -------
    Applicator
        Channels ``("ring", "tandem")``, ring frame at the origin (+z cranial, +x patient left).
    """
    try:
        dia = float(diameter_mm)
        ang = float(angle_deg)
    except (TypeError, ValueError):
        raise GeometryError(
            f"ring_applicator: diameter_mm and angle_deg must be numbers, got "
            f"{diameter_mm!r}, {angle_deg!r}"
        ) from None
    ring, info = ring_channel(dia, ang, **kwargs)
    tandem = tandem_channel()
    name = f"ring{dia:g}x{ang:g}"
    meta = {
        "diameter_mm": dia,
        "angle_deg": ang,
        "ring_lumen_diameter_mm": RING_LUMEN_DIAMETER_MM,
        "ring_r_a_mm": RING_R_A_MM,
        "flat_mm": float(kwargs.get("flat_mm", FLAT_MM)),
        "tip_to_first_dwell_mm": float(kwargs.get("tip_to_first_dwell_mm", TIP_TO_FIRST_DWELL_MM)),
        "tandem_lumen_diameter_mm": TANDEM_LUMEN_DIAMETER_MM,
        "construction": info,
        "sources": list(SOURCES),
        "assumptions": list(ASSUMPTIONS),
        "generator": "ringqa.geometry.parametric.ring_applicator",
    }
    return Applicator(
        name=name,
        channels=(ring, tandem),
        ring_centre_m=np.zeros(3),
        ring_normal=np.array([0.0, 0.0, 1.0]),
        ring_lateral=np.array([1.0, 0.0, 0.0]),
        ring_radius_m=mm_to_m(dia / 2.0),
        metadata=meta,
    )

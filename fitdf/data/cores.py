"""Physical data of the thesis's cores (Appendix A) that the fits cannot get from the DF alone.

Provides :class:`CoreGeometry` (turns, magnetic path length and iron section of a toroid,
and the conversions between winding and material units), :func:`core_geometry` (the
geometry of a thesis core from Appendix A), :func:`parse_geometry` (a user's core from
``turns=...,od=...,id=...,height=...``, the ``--geometry`` option),
:func:`appendix_a_ranges` (the printed material ranges), :func:`winding_resistance_estimate`
and the unit conversions. The laws work in winding units (current in A, flux linkage in
V s, ``N`` in H); with the turns ``N``, path length ``l_e`` and iron section ``A_e``::

    H = N i / l_e            (A/m;  1 Oe = 1000 / (4 pi) A/m)
    B = lambda / (N A_e)     (T;    1 T = 1e4 G)
    mu_r = L l_e / (mu_0 N^2 A_e)   (an inductance L as relative permeability, i.e.
                                     gauss/oersted, the unit Appendix A prints)

Notes
-----
Every candidate law is closed under a change of current scale (``N'(I) = s N(s I)`` is the
same law with other parameters), and scaling the core by ``s`` and the series resistance
``R`` by ``s`` leaves every measured point unchanged. Data at one source impedance therefore
determine a core only up to that scale, with the winding resistance along the degenerate
direction; a joint fit of 0 and 600 ohm data breaks the symmetry, and so does knowing
``r_w``, which :func:`winding_resistance_estimate` gives from Appendix A (turns, wire gauge,
core dimensions). The geometry rests on assumptions the thesis does not print: ``l_e`` is
the mean circumference ``pi (OD + ID) / 2`` (for these cores, ``OD/ID = 1.25``, the field
at the inner radius is 11 % above the mean); the printed dimensions are the bare
tape-wound core's, not its case's; the iron section is the gross section
``(OD - ID) / 2 x h`` times the stacking factor, the iron fraction of the section. The
thesis prints no tape thickness, so the stacking factor is a parameter of the geometry with
a range (:data:`STACKING_FACTOR_RANGE`) around its nominal value (:data:`STACKING_FACTOR`):
inductions and permeabilities derived from a fit scale as its inverse, and a fit does not
determine it (the DF data are in winding units).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fitdf.data.datasets import load
from fitdf.errors import OptionError
from fitdf.params import QUANTITIES

__all__ = [
    "winding_resistance_estimate",
    "AWG34_OHM_PER_M",
    "CASE_ALLOWANCE_IN",
    "CoreGeometry",
    "core_geometry",
    "appendix_a_ranges",
    "APPENDIX_A_MATERIAL_QUANTITIES",
    "MU_0",
    "A_PER_M_PER_OERSTED",
    "GAUSS_PER_TESLA",
    "STACKING_FACTOR",
    "STACKING_FACTOR_RANGE",
    "INCH",
    "oersted_to_a_per_m",
    "a_per_m_to_oersted",
    "tesla_to_gauss",
    "gauss_to_tesla",
]

#: Resistance of #34 AWG copper wire (0.160 mm, 20 degC): rho / area = 1.72e-8 / 2.01e-8 m^2.
AWG34_OHM_PER_M = 0.856
#: Case wall and clearance added on each side of the tape-wound core's cross-section (inch);
#: an assumption (the cases' dimensions are not printed), worth about +-20 % on the estimate.
CASE_ALLOWANCE_IN = 0.06
#: One inch in metre.
INCH = 0.0254
#: Permeability of vacuum (H/m), the classical ``4 pi 1e-7`` (the CGS units of Appendix A
#: are defined with it; the SI 2019 value differs by 1e-10, relative).
MU_0 = 4.0e-7 * math.pi
#: One oersted in A/m: ``1000 / (4 pi)`` = 79.577 A/m.
A_PER_M_PER_OERSTED = 1000.0 / (4.0 * math.pi)
#: Gauss per tesla.
GAUSS_PER_TESLA = 1.0e4
#: Nominal stacking (space) factor of the tape-wound cores: iron section / gross section.
#: Appendix A prints no tape thickness. Manufacturers' tables for tape-wound nickel-iron
#: cores (e.g. Magnetics Inc., *Tape Wound Cores* catalogue TWC-500, stacking factor by tape
#: thickness) give about 0.50 for 1/2-mil (13 um) tape, 0.75 for 1-mil, 0.83-0.85 for 2-mil
#: and 0.90 for 4-mil tape; 2-mil tape is the usual gauge of such cores for audio-frequency
#: and lower work, hence 0.85. ``A_e`` is proportional to it, so every flux density (B_p,
#: B_r) and relative permeability derived from a fit scales as ``1 / stacking_factor``
#: (fields H and the squareness B_r/B_p do not depend on it).
STACKING_FACTOR = 0.85
#: The range of stacking factors a thesis core may have (the uniform prior of the
#: parameter): the tapes of magnetic-amplifier cores, 1/2-mil to 4-mil, by the same tables.
STACKING_FACTOR_RANGE = (0.50, 0.90)

#: The material quantities of Appendix A that :func:`appendix_a_ranges` returns.
APPENDIX_A_MATERIAL_QUANTITIES = (
    "initial_permeability",
    "maximum_permeability",
    "coercive_force_Hc",
    "peak_flux_density_Bp",
    "residual_induction_Br",
    "squareness_Br_over_Bp",
)


def oersted_to_a_per_m(h_oe):
    """Field in A/m from oersted (``1 Oe = 1000 / (4 pi) A/m``)."""
    return np.asarray(h_oe, dtype=float) * A_PER_M_PER_OERSTED


def a_per_m_to_oersted(h):
    """Field in oersted from A/m."""
    return np.asarray(h, dtype=float) / A_PER_M_PER_OERSTED


def tesla_to_gauss(b):
    """Induction in gauss from tesla (``1 T = 1e4 G``)."""
    return np.asarray(b, dtype=float) * GAUSS_PER_TESLA


def gauss_to_tesla(b_gauss):
    """Induction in tesla from gauss."""
    return np.asarray(b_gauss, dtype=float) / GAUSS_PER_TESLA


def _rows(core, hint=""):
    table = load("appendix_a")
    rows = table[table["core"] == str(core).lower()]
    if rows.empty:
        raise OptionError(
            f"no Appendix A data for core {core!r} (known cores: "
            f"{', '.join(sorted(set(table['core'])))}){hint}"
        )
    return rows


def _value(rows, quantity):
    return float(rows.loc[rows["quantity"] == quantity, "value_min"].astype(float).iloc[0])


@dataclass(frozen=True)
class CoreGeometry:
    """Turns and magnetic dimensions of a toroidal core: the link between winding and material units.

    Parameters
    ----------
    turns : float
        Turns ``N`` of the driven winding (the winding whose current and flux linkage the
        fitted law describes).
    l_e : float
        Magnetic path length (m).
    a_e : float
        Effective iron cross-section (m^2), stacking factor included.
    r_winding_estimate : float or None
        DC resistance of the driven winding (ohm) if known or estimated, else None.
    name : str
        Label (the Appendix A core name, or the user's).
    stacking_factor : float or None
        Stacking factor used to get ``a_e`` from the gross section (None when ``a_e`` was
        given directly).
    stacking_range : tuple of float or None
        ``(low, high)`` stacking factors the core may have (the parameter's range; the
        material constants are reported over it). None, or ``low == high``: known.

    Notes
    -----
    Conversions (SI): ``H = N i / l_e``, ``B = lambda / (N A_e)``,
    ``mu_r = L l_e / (mu_0 N^2 A_e)``; their inverses are the methods :meth:`current`,
    :meth:`flux_linkage` and :meth:`inductance`. Oersted and gauss variants use
    ``1 Oe = 1000/(4 pi) A/m`` and ``1 T = 1e4 G``. All methods broadcast over arrays.
    """

    turns: float
    l_e: float
    a_e: float
    r_winding_estimate: float | None = None
    name: str = ""
    stacking_factor: float | None = None
    stacking_range: tuple[float, float] | None = None

    def __post_init__(self):
        for field_name in ("turns", "l_e", "a_e"):
            value = getattr(self, field_name)
            if not (np.isfinite(value) and value > 0):
                raise OptionError(
                    f"core geometry: {field_name} must be a positive number, got {value!r}"
                )
        if self.stacking_range is not None:
            low, high = self.stacking_range
            sf = self.stacking_factor
            if not (0 < low <= high <= 1) or (sf is not None and not low <= sf <= high):
                raise OptionError(
                    f"core geometry: stacking range {self.stacking_range!r} must lie in (0, 1] "
                    f"and hold the stacking factor {sf!r}"
                )

    @classmethod
    def from_dimensions(
        cls,
        turns,
        outside_diameter,
        inside_diameter,
        height,
        *,
        stacking_factor=STACKING_FACTOR,
        stacking_range=None,
        r_winding_estimate=None,
        name="",
    ):
        """Geometry of a tape-wound toroid from its dimensions (SI: metre).

        Parameters
        ----------
        turns : float
            Turns of the driven winding.
        outside_diameter, inside_diameter, height : float
            Bare core dimensions (m), ``outside_diameter > inside_diameter``.
        stacking_factor : float
            Iron fraction of the gross section, in ``(0, 1]``; see :data:`STACKING_FACTOR`.
        stacking_range : tuple of float, optional
            The range the stacking factor may lie in, holding ``stacking_factor`` (None:
            it is known).
        r_winding_estimate : float, optional
            Winding resistance (ohm) to carry along.
        name : str
            Label.

        Returns
        -------
        CoreGeometry
            ``l_e = pi (OD + ID) / 2`` (mean circumference) and
            ``a_e = (OD - ID) / 2 * height * stacking_factor``.
        """
        od, idia, h = float(outside_diameter), float(inside_diameter), float(height)
        sf = float(stacking_factor)
        if not (od > idia > 0 and h > 0):
            raise OptionError(
                f"core dimensions: need outside diameter > inside diameter > 0 and height > 0, "
                f"got outside {od * 1e3:g} mm, inside {idia * 1e3:g} mm, height {h * 1e3:g} mm"
            )
        if not 0 < sf <= 1:
            raise OptionError(f"stacking factor must lie in (0, 1], got {sf!r}")
        return cls(
            turns=float(turns),
            l_e=math.pi * (od + idia) / 2.0,
            a_e=(od - idia) / 2.0 * h * sf,
            r_winding_estimate=None if r_winding_estimate is None else float(r_winding_estimate),
            name=str(name),
            stacking_factor=sf,
            stacking_range=None if stacking_range is None else tuple(map(float, stacking_range)),
        )

    # --- the iron fraction ----------------------------------------------------------------
    @property
    def iron_fraction_spread(self) -> tuple[float, float]:
        """``(low, high)`` multipliers of a derived induction or permeability over the stacking
        range, relative to its value at :attr:`stacking_factor` (``B`` and ``mu_r`` scale as
        ``1 / stacking_factor``): ``(sf / high, sf / low)``; ``(1, 1)`` when it is known."""
        if self.stacking_range is None or self.stacking_factor is None:
            return 1.0, 1.0
        low, high = self.stacking_range
        return self.stacking_factor / high, self.stacking_factor / low

    def stacking_factor_for_induction(self, flux_linkage, induction):
        """The stacking factor at which ``flux_linkage`` (V s) is the induction ``induction``
        (T): ``lambda / (N A_gross B)``; None without a stacking factor (``a_e`` given)."""
        if self.stacking_factor is None:
            return None
        gross = self.a_e / self.stacking_factor
        return np.asarray(flux_linkage, dtype=float) / (
            self.turns * gross * np.asarray(induction, dtype=float)
        )

    # --- scale factors -------------------------------------------------------------------
    @property
    def field_per_ampere(self) -> float:
        """``N / l_e``: field (A/m) per ampere of winding current."""
        return self.turns / self.l_e

    @property
    def inductance_per_permeability(self) -> float:
        """``mu_0 N^2 A_e / l_e``: inductance (H) per unit relative permeability."""
        return MU_0 * self.turns**2 * self.a_e / self.l_e

    # --- winding -> material -------------------------------------------------------------
    def field(self, current):
        """Field ``H = N i / l_e`` (A/m) of a winding current ``i`` (A)."""
        return np.asarray(current, dtype=float) * self.field_per_ampere

    def field_oe(self, current):
        """Field (oersted) of a winding current (A)."""
        return a_per_m_to_oersted(self.field(current))

    def induction(self, flux_linkage):
        """Induction ``B = lambda / (N A_e)`` (T) of a flux linkage (V s)."""
        return np.asarray(flux_linkage, dtype=float) / (self.turns * self.a_e)

    def induction_gauss(self, flux_linkage):
        """Induction (gauss) of a flux linkage (V s)."""
        return tesla_to_gauss(self.induction(flux_linkage))

    def relative_permeability(self, inductance):
        """``mu_r = L l_e / (mu_0 N^2 A_e)`` of an inductance ``L`` (H) (numerically gauss/oersted)."""
        return np.asarray(inductance, dtype=float) / self.inductance_per_permeability

    # --- material -> winding -------------------------------------------------------------
    def current(self, field):
        """Winding current (A) giving the field ``H`` (A/m)."""
        return np.asarray(field, dtype=float) / self.field_per_ampere

    def current_oe(self, field_oe):
        """Winding current (A) giving the field ``H`` (oersted)."""
        return self.current(oersted_to_a_per_m(field_oe))

    def flux_linkage(self, induction):
        """Flux linkage (V s) of the induction ``B`` (T)."""
        return np.asarray(induction, dtype=float) * (self.turns * self.a_e)

    def flux_linkage_gauss(self, induction_gauss):
        """Flux linkage (V s) of the induction ``B`` (gauss)."""
        return self.flux_linkage(gauss_to_tesla(induction_gauss))

    def inductance(self, mu_r):
        """Inductance (H) of the winding on a core of relative permeability ``mu_r``."""
        return np.asarray(mu_r, dtype=float) * self.inductance_per_permeability

    # --- physical parameter boxes -------------------------------------------------------
    def winding_scale(self, quantity: str) -> float:
        """Winding-unit value per SI material value of ``quantity`` (:data:`fitdf.params.QUANTITIES`)."""
        p, q = QUANTITIES[quantity]
        return (self.turns * self.a_e) ** p * (self.l_e / self.turns) ** q

    def winding_box(self, quantity: str):
        """``(low, typical, high)`` in winding units from :data:`MATERIAL_LIMITS`, or None.

        None for quantities without material limits (their declared bounds stand).
        """
        if quantity not in MATERIAL_LIMITS:
            return None
        _, lo, typical, hi, si_per_unit = MATERIAL_LIMITS[quantity]
        scale = self.winding_scale(quantity) * si_per_unit
        return lo * scale, typical * scale, hi * scale

    def to_dict(self) -> dict:
        """Plain-float summary (SI), with the scale factors."""
        return {
            "name": self.name,
            "turns": float(self.turns),
            "l_e_m": float(self.l_e),
            "a_e_m2": float(self.a_e),
            "stacking_factor": self.stacking_factor,
            "stacking_range": None if self.stacking_range is None else list(self.stacking_range),
            "r_winding_estimate_ohm": self.r_winding_estimate,
            "field_a_per_m_per_ampere": float(self.field_per_ampere),
            "inductance_h_per_mu_r": float(self.inductance_per_permeability),
        }


#: Physical limits of soft-magnetic materials, per winding quantity: (material quantity, low,
#: typical, high, SI per unit). They bound a fit in material terms instead of arbitrary
#: winding-unit boxes: relative permeability 30 to 3e6 (gapped ferrite to the best
#: Supermalloy), field 1e-3 to 1e3 A/m (1.3e-5 to 13 Oe: coercive forces and loop widths of
#: soft alloys), induction 0.01 to 2.5 T (above any saturation induction), and a relative
#: Rayleigh constant 0.1 to 1e9 m/A.
MATERIAL_LIMITS = {
    "inductance": ("relative permeability", 30.0, 1.0e4, 3.0e6, MU_0),
    "current": ("field, A/m", 1.0e-3, 2.0, 1.0e3, 1.0),
    "flux_linkage": ("induction, T", 0.01, 0.7, 2.5, 1.0),
    "inductance_per_current": ("relative Rayleigh constant, m/A", 0.1, 1.0e4, 1.0e9, MU_0),
    # Bertotti's dynamic-field coefficients (fitdf.chains.dynamic, whose docstring gives the
    # sources): classical k_cl = sigma d^2 / 12 from 1e-7 S m (negligible; a 3 um tape is
    # 1.3e-6) to 0.3 S m (a 0.36 mm tape at 2.2e6 S/m with an anomaly factor of 10), typical
    # 1e-4 (1 mil Supermalloy, 8e-5); excess k_ex = (sigma G S V0)^(1/2) from 1e-4
    # (negligible) to 10 A m^-1 (T/s)^-1/2 (0.36 x 25 mm tape, V0 = 10 A/m), typical 0.1
    "conductance": ("classical eddy-current coefficient k_cl, S m", 1.0e-7, 1.0e-4, 0.3, 1.0),
    "current_per_root_voltage": (
        "excess-loss coefficient k_ex, A m^-1 (T/s)^-1/2",
        1.0e-4,
        0.1,
        10.0,
        1.0,
    ),
}


def core_geometry(
    core: str, *, stacking_factor=STACKING_FACTOR, stacking_range="auto"
) -> CoreGeometry:
    """Geometry of a thesis core from Appendix A (primary winding, bare core dimensions).

    Parameters
    ----------
    core : str
        ``"permalloy"``, ``"deltamax"`` or ``"supermalloy"``.
    stacking_factor : float
        Iron fraction of the gross section; the default :data:`STACKING_FACTOR` (0.85)
        is an assumption, see there.
    stacking_range : tuple of float, None or "auto"
        The range it may lie in; ``"auto"`` (default): :data:`STACKING_FACTOR_RANGE` with
        the nominal stacking factor, None (known) with one given.

    Returns
    -------
    CoreGeometry
        With ``r_winding_estimate`` from :func:`winding_resistance_estimate`. Permalloy and
        Supermalloy (1250 turns, 2.5 x 2.0 x 0.5 in): ``l_e = 0.1795 m``,
        ``a_e = 6.85e-5 m^2`` at 0.85; Deltamax (2000 turns, 1.25 x 1.0 x 0.125 in):
        ``l_e = 0.0898 m``, ``a_e = 8.57e-6 m^2``.
    """
    rows = _rows(core, ": give the geometry with CoreGeometry.from_dimensions")
    od, idia, h = (
        _value(rows, q) * INCH
        for q in ("core_outside_diameter", "core_inside_diameter", "core_height")
    )
    return CoreGeometry.from_dimensions(
        _value(rows, "primary_turns"),
        od,
        idia,
        h,
        stacking_factor=stacking_factor,
        stacking_range=_stacking_range(stacking_factor, stacking_range),
        r_winding_estimate=winding_resistance_estimate(core),
        name=str(core).lower(),
    )


def _stacking_range(stacking_factor, stacking_range):
    """``stacking_range`` with ``"auto"`` resolved: the nominal range for the nominal factor,
    None (known) for a stated one."""
    if isinstance(stacking_range, str) and stacking_range == "auto":
        return STACKING_FACTOR_RANGE if stacking_factor == STACKING_FACTOR else None
    return stacking_range


def appendix_a_ranges(core: str) -> dict[str, tuple[float, float | None, str]]:
    """Printed material ranges of a thesis core (Appendix A), in its units.

    Parameters
    ----------
    core : str
        ``"permalloy"``, ``"deltamax"`` or ``"supermalloy"``.

    Returns
    -------
    dict
        ``quantity -> (low, high, unit)`` for the quantities of
        :data:`APPENDIX_A_MATERIAL_QUANTITIES`: permeabilities in gauss/oersted, inductions
        in gauss, ``coercive_force_Hc`` in oersted, the squareness ratio with unit ``""``.
        ``high`` is None where only a minimum is printed (Deltamax squareness "0.92 min.").
        Where the table repeats a quantity over several rows the result is the union
        ``[min of lows, max of highs]``; for the coercive force this joins three ranges
        whose test conditions (peak fields) the OCR lost, so it is wider than any one of
        them (Permalloy 0.02-0.25 Oe). The row-to-quantity assignment of the garbled
        Appendix A is that of ``datasets/appendix_a.csv`` (see its notes column).
    """
    rows = _rows(core)
    out = {}
    for quantity in APPENDIX_A_MATERIAL_QUANTITIES:
        sel = rows[rows["quantity"] == quantity]
        if sel.empty:
            continue
        lows = sel["value_min"].astype(float)
        highs = sel["value_max"].astype(float)
        high = None if highs.isna().any() else float(highs.max())
        unit = sel["unit"].fillna("").astype(str).iloc[0]
        out[quantity] = (float(lows.min()), high, "" if unit == "nan" else unit)
    return out


def winding_resistance_estimate(core: str) -> float:
    """DC resistance (ohm) of the driven winding of a thesis core, from Appendix A.

    ``turns x mean turn length x 0.856 ohm/m`` (#34 wire), with the mean turn the perimeter
    of the cased core's cross-section: ``2 ((OD - ID)/2 + h + 4 t)``, ``t`` =
    :data:`CASE_ALLOWANCE_IN`. Gives about 54 ohm (Permalloy, Supermalloy: 1250 turns on a
    2.5 x 2.0 x 0.5 in core) and 43 ohm (Deltamax: 2000 turns on 1.25 x 1.0 x 0.125 in).
    An estimate to perhaps 30 %: the thesis prints no winding resistance.
    """
    rows = _rows(core, ": give the winding resistance explicitly")
    od, idia, h = (
        _value(rows, q) for q in ("core_outside_diameter", "core_inside_diameter", "core_height")
    )
    turns = _value(rows, "primary_turns")
    turn_m = 2.0 * ((od - idia) / 2.0 + h + 4.0 * CASE_ALLOWANCE_IN) * INCH
    return float(np.round(turns * turn_m * AWG34_OHM_PER_M, 1))


#: Length units a geometry text may use, in metres.
_LENGTH_UNITS = {"mm": 1e-3, "cm": 1e-2, "m": 1.0, "in": INCH}
_GEOMETRY_KEYS = ("turns", "od", "id", "height", "stacking", "r_winding")


def _length(key: str, text: str) -> float:
    for unit in sorted(_LENGTH_UNITS, key=len, reverse=True):
        if text.endswith(unit):
            try:
                return float(text[: -len(unit)]) * _LENGTH_UNITS[unit]
            except ValueError:
                break
    raise OptionError(
        f"geometry: {key}={text!r} needs a number with a unit ({', '.join(_LENGTH_UNITS)}), e.g. 63.5mm"
    )


def parse_geometry(text: str, name: str = "user core") -> CoreGeometry:
    """A user's core from ``"turns=1250,od=63.5mm,id=50.8mm,height=12.7mm[,stacking=0.85][,r_winding=54]"``.

    ``text`` may also be the path of a small file holding the same ``key=value`` pairs
    (commas or new lines between them; ``#`` starts a comment). Lengths need a unit (mm,
    cm, m, in); ``r_winding`` (ohm) is optional and, when given, centres the winding
    resistance prior. Errors are one-line :class:`OptionError` naming the key.
    """
    raw = str(text)
    source = "geometry"
    path = Path(raw)
    try:
        is_file = "=" not in raw and path.is_file()
        if is_file:
            source = str(path)
            text = path.read_text(encoding="utf-8")
            raw = "\n".join(line.split("#", 1)[0] for line in text.splitlines())
    except (OSError, UnicodeDecodeError) as exc:  # name too long, unreadable, not text
        shown = raw if len(raw) <= 80 else raw[:77] + "..."
        reason = getattr(exc, "strerror", None) or exc
        raise OptionError(f"geometry {shown}: cannot be read ({reason})") from None
    pairs = {}
    for item in raw.replace("\n", ",").split(","):
        if not item.strip():
            continue
        key, sep, value = (part.strip() for part in item.partition("="))
        if not sep or key not in _GEOMETRY_KEYS:
            raise OptionError(
                f"{source}: cannot read {item.strip()!r}; expected key=value with keys "
                f"{', '.join(_GEOMETRY_KEYS)}"
            )
        pairs[key] = value
    missing = [k for k in ("turns", "od", "id", "height") if k not in pairs]
    if missing:
        raise OptionError(f"{source}: missing {', '.join(missing)} (e.g. turns=1250,od=63.5mm,...)")

    def number(key):
        try:
            value = float(pairs[key])
        except ValueError:
            raise OptionError(f"{source}: {key}={pairs[key]!r} is not a number") from None
        if not (math.isfinite(value) and value > 0):
            raise OptionError(f"{source}: {key} must be positive, got {pairs[key]}")
        return value

    od, idia = _length("od", pairs["od"]), _length("id", pairs["id"])
    if not od > idia:  # said in the user's own units
        raise OptionError(
            f"{source}: od={pairs['od']} must be larger than id={pairs['id']} (the outside and "
            "inside diameters of the toroid)"
        )
    return CoreGeometry.from_dimensions(
        number("turns"),
        od,
        idia,
        _length("height", pairs["height"]),
        stacking_factor=number("stacking") if "stacking" in pairs else STACKING_FACTOR,
        # a stated stacking factor is known; without one, it lies in the range of tape cores
        stacking_range=None if "stacking" in pairs else STACKING_FACTOR_RANGE,
        r_winding_estimate=number("r_winding") if "r_winding" in pairs else None,
        name=name,
    )

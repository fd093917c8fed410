"""The names of drivebench's quantities and terms: each quantity's one name, its unit and
what it means (docs/names.md is this table: ``python -m kernel.names > docs/names.md``;
``tests/test_names.py`` checks both against the code).

A column, field, key or variable holding a quantity carries the quantity's name; its
unit is the name's suffix, read by :func:`kernel.units.unit_of` from
:data:`kernel.units.UNIT_SUFFIXES`, the one units source (the Parquet field metadata, the
OCP's output columns and the drive rating's messages all read it). A term is a word of
the code's vocabulary that must not stand for two things.
"""

from __future__ import annotations

from dataclasses import dataclass

from kernel.units import UNIT_SUFFIXES, unit_of

#: the winding temperature, a state of the OCP with a thermal model [degC]
WINDING_TEMPERATURE = "theta_winding_c"
#: the wind speed at the reference height: a scenario's parameter [m/s]
WIND_SPEED = "wind_speed_m_s"
#: the wind speed at the kite, from the wind profile at its altitude [m/s]
LOCAL_WIND = "wind_m_s"


@dataclass(frozen=True)
class Name:
    """One quantity's name.

    Attributes
    ----------
    name : str
        The one name (its suffix gives the unit).
    meaning : str
        What it is, with its sign convention.
    retired : tuple of str
        Names it had before; none of them is used for anything in product code.
    """

    name: str
    meaning: str
    retired: tuple[str, ...] = ()

    @property
    def unit(self) -> str:
        """The unit of the name's suffix (:func:`kernel.units.unit_of`)."""
        return unit_of(self.name)


@dataclass(frozen=True)
class Term:
    """A word of the code's vocabulary and the one thing it names.

    Attributes
    ----------
    term : str
    meaning : str
    spelled : str
        Where and how the code spells it.
    """

    term: str
    meaning: str
    spelled: str


#: the quantities that cross a module or a file, by stage
QUANTITIES: tuple[Name, ...] = (
    Name(WIND_SPEED, "wind speed at the reference height (100 m): a scenario's parameter, "
         "the axis of the power curves and of the site's distribution", ("wind_ref_m_s",)),
    Name("wind_speeds_m_s", "the wind speeds at the reference height of a sweep (a tuple, "
         "increasing; the manifest's list)", ("winds", "winds_m_s")),
    Name(LOCAL_WIND, "wind speed at the kite: the wind profile at its altitude (trajectory "
         "column); never the reference wind"),
    Name("speed_rpm", "speed of the power model's shaft (the drum times the gear ratio)"),
    Name("torque_nm", "torque the drive delivers at its shaft (positive: driving the shaft)"),
    Name("p_elec_w", "electrical power, positive when drawn from the grid"),
    Name("p_mech_w", "mechanical power, positive when the drive delivers it to the shaft"),
    Name("avg_p_elec_w", "cycle average of p_elec_w (negative: generated)"),
    Name("avg_p_mech_w", "cycle average of p_mech_w (negative: generated)"),
    Name("e_elec_j", "net electrical energy per cycle (negative: generated)"),
    Name("e_mech_j", "net mechanical energy per cycle (negative: generated)"),
    Name("period_s", "cycle period"),
    Name("time_s", "time since the cycle's start"),
    Name("l_m", "tether length"),
    Name("dl_m_s", "reel-out speed (positive: tether paid out)"),
    Name("ddl_m_s2", "reel-out acceleration"),
    Name("tension_n", "tether tension at the kite"),
    Name("nu_n_per_m", "the tether constraint's multiplier: tension per tether length",
         ("nu_n_m",)),
    Name("altitude_m", "kite altitude above ground"),
    Name("airspeed_m_s", "kite airspeed"),
    Name(WINDING_TEMPERATURE, "winding temperature (a state with a thermal model)"),
    Name("theta_housing_c", "housing temperature (the thermal network's second node)"),
    Name("nominal_power_w", "the drive's nominal power (capacity factor, % of nominal)"),
    Name("max_speed_rpm", "the drive's speed limit"),
    Name("max_torque_nm", "the drive's short-time torque limit"),
    Name("continuous_torque_nm", "the drive's continuous (RMS over a cycle) torque rating"),
    Name("max_p_elec_w", "the grid power limit"),
    Name("cut_in_m_s", "cut-in wind speed at the reference height: the average electrical "
         "power crosses zero"),
)

#: words that named two things before; each now names one
TERMS: tuple[Term, ...] = (
    Term("kite model", "the kite's dynamics: states, controls and the DAE the OCP integrates",
         "`optimize/model/`, `kite_dae`, `DaeSpec`"),
    Term("drive model", "the drive's losses, electrical power over speed and torque (the "
         "power model a fit writes)",
         "`fitting.power_model.PowerModel`, `drive_model`, `--drive-model`, "
         "`power_model.json`"),
    Term("Objective", "a cycle-average power an optimization maximizes, with its summary "
         "column", "`optimize.kinds.Objective` (a dataclass)"),
    Term("ObjectiveName", "the name of an objective, `\"electrical\"` or `\"mechanical\"`",
         "`optimize.problem.scenario.ObjectiveName` (a `Literal`)"),
    Term("scenario", "one optimization case: a kind at a wind speed; what a sweep's plan, "
         "the solve service and the backend pass on, named `\"elec-lim-7.0\"`",
         "`optimize.problem.scenario.Scenario`"),
    Term("kind", "a scenario kind: the objective maximized and whether the drive limits "
         "apply (`\"elec-lim\"`); the OCP's layout has a `name`, a model's variables come "
         "in `vectors` (states, controls, ...)",
         "`optimize.kinds.Kind`, `KINDS`, `Scenario.kind`, `--scenarios`"),
    Term("backend", "the numerical side of the solve service: builds a problem's NLP and "
         "solves a scenario on it (a test's stand-in is one too)",
         "`optimize.service.builder.Backend` (a protocol), `OcpBackend`"),
    Term("solver", "the NLP solver: what solves one NLP, IPOPT or fatrop, created once "
         "per setting", "`--solver`, `SolverOptions.solver`, `optimize.solve.nlp_solver`"),
    Term("solves", "one problem's solves on one worker: their records, outcomes and warm "
         "starts (what the solve service's chains, retries and re-solves work on)",
         "`optimize.service.solves.Solves`"),
    Term("warm start", "a solve from another solve's optimum (a neighbouring wind speed, "
         "another kind, another problem's carried over)",
         "`optimize.solve.solve.solve`, `Backend.solve`"),
    Term("cold start", "a problem's first solve, with no optimum at hand: from the stored "
         "guess where it fits, else by the homotopy",
         "`optimize.solve.starts.cold.start`, `Backend.cold_start`"),
    Term("homotopy", "the cold start's way from the parts' own guesses: tracking, "
         "penalized, then the power stages",
         "`optimize.solve.starts.homotopy.solve_by_homotopy`"),
)


def render() -> str:
    """docs/names.md: the units, the quantities and the terms as Markdown tables."""
    lines = ["# Names", "",
             "Generated from `kernel/names.py` (`python -m kernel.names > docs/names.md`); "
             "`tests/test_names.py` checks it. A quantity has one name; the name's suffix is "
             "its unit (`kernel/units.py`, the one units source).", "",
             "## Unit suffixes", "", "| suffix | unit |", "|---|---|"]
    lines += [f"| `{suffix}` | {unit} |" for suffix, unit in UNIT_SUFFIXES]
    lines += ["", "## Quantities", "", "| name | unit | meaning | not called |",
              "|---|---|---|---|"]
    lines += [f"| `{q.name}` | {q.unit} | {q.meaning} | "
              f"{', '.join(f'`{r}`' for r in q.retired)} |" for q in QUANTITIES]
    lines += ["", "## Terms", "", "| term | means | in the code |", "|---|---|---|"]
    lines += [f"| {t.term} | {t.meaning} | {t.spelled} |" for t in TERMS]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(render(), end="")

"""The rings against Cassini in the study reports (``ringsim.study.cassini``).

* the summary's ``occultation`` from views of the bar model itself: the fit returns the
  model's H/W, gap tau and wake angle, and the asymmetry is the model's, by hand;
* the rule of "consistent with" on constructed summaries (A ring, B ring, both, excluded,
  no wake, not measured, no self-gravity);
* a study with a tiny gravitating case: its summary holds the occultations, report.json and
  report.md the table with units, ``--report-only`` gives the same bytes, a summary without
  the occultations still renders ("not measured") and is completed from the run file with
  its cost kept;
* the committed quick report of studies/kappa-selfgravity comes back from its summaries.
"""

from __future__ import annotations

import copy
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

import ringsim
from ringsim.analysis import wake_model
from ringsim.config.study import load_study
from ringsim.study import cassini, markdown, run_study
from ringsim.study.runs import SUMMARY_FORMAT, collect

ROOT = Path(__file__).resolve().parent.parent
#: The bar model's parameters of the constructed views: S/lambda, H/lambda, tau_G, phi_W
#: [deg]; H/W = 0.04 / (1 - 0.8) = 0.2, wake angle from radial 180 - 112 = 68 deg; at
#: B = 3.45 deg across the bars 0.8 - 0.04 / tan B = 0.14 of the light still passes.
BARS = (0.8, 0.04, 0.25, 112.0)
ELEVATIONS = (3.45, 10.0, 20.0, 45.0, 90.0)
AZIMUTHS = tuple(float(a) for a in range(0, 360, 15))


def _bar_views(noise: float = 0.0) -> list[dict]:
    """Views of the bar model at the observe defaults, tau_n with a 1 % standard error (and
    ``noise`` times that as seeded Gaussian noise)."""
    rng = np.random.default_rng(4)
    views = []
    for b in ELEVATIONS:
        for a in AZIMUTHS:
            T = float(wake_model.bar_transmission(b, a, *BARS))
            tau = -math.sin(math.radians(b)) * math.log(T)
            err = 0.01 * tau
            views.append({"elevation_deg": b, "azimuth_deg": a, "transmission": T,
                          "transmission_stderr": T * err / math.sin(math.radians(b)),
                          "normal_optical_depth": tau + noise * err * rng.normal(),
                          "normal_optical_depth_stderr": err})
    return views


def _observation(views: list[dict]) -> dict:
    """What ``analysis.observe.observe`` returns, as far as `cassini.condense` reads it."""
    fit = wake_model.fit_bar_model(*(np.array([v[k] for v in views]) for k in (
        "elevation_deg", "azimuth_deg", "normal_optical_depth",
        "normal_optical_depth_stderr")))
    return {"snapshots": [3, 4], "snapshot_orbits": [1.5, 2.0], "views": views,
            "precision": 0.01, "geometric_optical_depth": 0.5, "bar_model": fit}


def test_condensed_occultation_returns_the_bar_models_numbers():
    """Views of the bar model (1 % noise): the fit gives H/W = 0.2 and the wake angle 68 deg
    within 4 standard errors; the asymmetry at B = 3.45 deg is (max - min) / mean of the
    model's own tau_n over the 24 azimuths, and the peak transmission the model's T at the
    azimuth of the grid nearest the bars, 105 deg, 7 deg off them: (S/lambda - (H/lambda)
    sin 7 deg / tan B) exp(-tau_G / sin B) (exact: no noise on T)."""
    occ = cassini.condense(_observation(_bar_views(noise=1.0)), wake_significant=True)
    assert occ["fitted"] and occ["wake_significant"] and occ["azimuths"] == 24
    assert occ["elevations_deg"] == list(ELEVATIONS)
    hw, angle = occ["height_over_width"], occ["wake_angle_from_radial_deg"]
    assert hw["units"] == "dimensionless" and angle["units"] == "deg"
    assert abs(hw["mean"] - 0.2) < 4 * hw["stderr"] and hw["stderr"] < 0.05
    assert abs(angle["mean"] - 68.0) < 4 * angle["stderr"] and angle["stderr"] < 2.0
    assert abs(occ["gap_optical_depth"]["mean"] - 0.25) < 4 * occ["gap_optical_depth"]["stderr"]
    low = occ["asymmetry"][0]
    assert low["elevation_deg"] == 3.45
    exact = [v for v in _bar_views() if v["elevation_deg"] == 3.45]
    tau = np.array([v["normal_optical_depth"] for v in exact])
    noisy = [v for v in _bar_views(noise=1.0) if v["elevation_deg"] == 3.45]
    noisy_tau = np.array([v["normal_optical_depth"] for v in noisy])
    amplitude = low["asymmetry_amplitude"]
    assert amplitude["mean"] == pytest.approx(
        (noisy_tau.max() - noisy_tau.min()) / noisy_tau.mean(), rel=1e-12)
    assert abs(amplitude["mean"] - (tau.max() - tau.min()) / tau.mean()) < 4 * amplitude["stderr"]
    b = math.radians(3.45)
    peak = (0.8 - 0.04 * math.sin(math.radians(7.0)) / math.tan(b)) * math.exp(
        -0.25 / math.sin(b))
    assert low["peak_transmission"]["mean"] == pytest.approx(peak, rel=1e-12)
    assert low["peak_transmission_azimuth_deg"] == 105.0


def test_an_opaque_view_leaves_the_asymmetry_unmeasured():
    """A view with no ray through (T = 0, tau_n infinite) gives no amplitude, not a
    number made of a lower bound."""
    views = _bar_views()
    views[0] = {**views[0], "transmission": 0.0, "normal_optical_depth": math.inf,
                "normal_optical_depth_stderr": math.nan}
    occ = cassini.condense(_observation(views), wake_significant=True)
    assert math.isnan(occ["asymmetry"][0]["asymmetry_amplitude"]["mean"])
    assert math.isfinite(occ["asymmetry"][1]["asymmetry_amplitude"]["mean"])


def _value(mean: float, stderr: float, units: str = "dimensionless") -> dict:
    return {"mean": mean, "stderr": stderr, "units": units}


def _summary(gravity: bool = True, hw=(0.25, 0.02), angle=(68.0, 1.0), gap=(0.3, 0.02),
             wake: bool = True, occultation: bool = True) -> dict:
    """A summary as far as the table reads it."""
    scenario = {"sheet": {"gravity": gravity, "optical_depth": 0.5},
                "particles": {"size_distribution": {"kind": "monodisperse", "radius": 1.0}},
                "restitution": {"kappa": 0.1}}
    out: dict = {"scenario": scenario}
    if gravity and occultation:
        out["occultation"] = {
            "height_over_width": _value(*hw), "gap_optical_depth": _value(*gap),
            "wake_angle_from_radial_deg": _value(*angle, "deg"),
            "geometric_optical_depth": _value(0.5, 0.0), "fitted": True,
            "wake_significant": wake,
            "asymmetry": [{"elevation_deg": 3.45, "asymmetry_amplitude": _value(0.9, 0.05),
                           "peak_transmission": _value(0.05, 0.005),
                           "peak_transmission_azimuth_deg": 105.0}]}
    return out


@pytest.mark.parametrize("summaries, verdict", [
    ([_summary(), _summary(hw=(0.27, 0.02))], "A ring"),
    ([_summary(hw=(0.05, 0.01), angle=(30.0, 2.0), gap=(0.2, 0.02))] * 2, "B ring"),
    # 0.12 +- 2 x 0.02 reaches both 0.15 (A) and 0.1 (B)
    ([_summary(hw=(0.12, 0.02), angle=(68.0, 1.0), gap=(0.3, 0.02))], "A ring and B ring"),
    ([_summary(hw=(0.6, 0.05), angle=(45.0, 2.0), gap=(0.8, 0.02))] * 2, "excluded"),
    # the A ring's H/W but the angle 3 sigma off 64-72 deg; gap 0.8 excludes the B ring
    ([_summary(angle=(78.0, 2.0), gap=(0.8, 0.02))], "excluded"),
    ([_summary(), _summary(wake=False)], "no significant wake"),
    ([_summary(occultation=False)] * 2, "not measured"),
    ([_summary(gravity=False)] * 2, "no wakes (no self-gravity)"),
])
def test_the_rule_of_consistent_with(summaries, verdict):
    """The 2-sigma rule of `cassini.RULE` against the published ranges of `PUBLISHED`."""
    table = cassini.against_cassini({"case": summaries, "other": [_summary()]})
    assert table is not None and table["cases"]["case"]["verdict"] == verdict


def test_the_table_shows_the_largest_reduced_chi2_of_the_fits():
    """The case's ``fit_reduced_chi2_max``: the largest of its seeds with a wake and a fit;
    the errors are the fits' as the summaries hold them (wake_model scales them by
    sqrt(reduced chi^2) already: tests/test_fit.py), not scaled again."""
    def with_chi2(chi2, wake=True):
        summary = _summary(hw=(0.45, 0.02), gap=(0.8, 0.02), wake=wake)
        summary["occultation"]["fit_reduced_chi2"] = chi2
        return summary

    table = cassini.against_cassini({"c": [with_chi2(16.0), with_chi2(3.0)],
                                     "d": [with_chi2(9.0, wake=False)]})
    assert table is not None
    entry = table["cases"]["c"]
    assert entry["fit_reduced_chi2_max"] == 16.0
    assert entry["height_over_width"]["stderr_propagated"] == pytest.approx(
        0.02 / math.sqrt(2), rel=1e-12)
    assert entry["verdict"] == "excluded"
    assert table["cases"]["d"]["fit_reduced_chi2_max"] is None


def test_seed_mean_and_a_seed_without_occultations():
    """The case is the mean over the seeds that have the occultations (budget.replica_mean);
    a seed whose summary lacks them is left out and counted."""
    table = cassini.against_cassini({"c": [_summary(hw=(0.2, 0.01)), _summary(hw=(0.3, 0.01)),
                                           _summary(occultation=False)]})
    assert table is not None
    entry = table["cases"]["c"]
    assert entry["seeds_measured"] == 2
    hw = entry["height_over_width"]
    assert hw["mean"] == pytest.approx(0.25) and hw["units"] == "dimensionless"
    assert hw["stderr"] == pytest.approx(0.05), "the seed scatter, larger than 0.007"
    assert cassini.against_cassini({"c": [_summary(gravity=False)]}) is None


def test_bar_model_only_from_seeds_with_a_wake():
    """A seed without a significant wake adds its occultation but not its bar-model fit
    (unconstrained without wakes: H/W 1e12 +- 1e26 was seen) to the case's means."""
    table = cassini.against_cassini({"c": [_summary(hw=(0.2, 0.01)),
                                           _summary(hw=(6e12, 1e26), wake=False)]})
    assert table is not None
    entry = table["cases"]["c"]
    assert entry["seeds_measured"] == 2 and entry["seeds_with_wake"] == 1
    assert entry["height_over_width"]["mean"] == pytest.approx(0.2)
    assert entry["height_over_width"]["stderr"] == pytest.approx(0.01)
    assert entry["geometric_optical_depth"] is not None
    md = "\n".join(markdown.cassini_section({"against_cassini": table}))
    assert "| 2 (1 with a wake) | 0.2 ± 0.01 |" in md


# --- a study with a gravitating case -------------------------------------------------------

SCENARIO = """\
name: tinygrav
seed: 1
planet: {GM: 3.7931e16, a: 1.0e8}
particles:
  density: 900.0
  size_distribution: {kind: monodisperse, radius: 1.0}
sheet: {optical_depth: 0.2, n_particles: 200}
restitution: {model: dilley, xi0: 0.16, p: 0.65, kappa: 0.0}
integration: {orbits: 0.2}
output: {timeseries_every: 0.05, snapshot_every: 0.1}
"""
STUDY = """\
name: tiny-gravity
base: tiny.yaml
seeds: [1]
cases:
  plain: {}
  gravity: {sheet.gravity: true}
length: {orbits: 0.2}
"""
COMMAND = "ringsim study study.yaml"


def _write(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "tiny.yaml").write_text(SCENARIO)
    (folder / "study.yaml").write_text(STUDY)
    return folder / "study.yaml"


@pytest.fixture(scope="module")
def grav_study(tmp_path_factory):
    """The tiny study run once: one run without and one with self-gravity."""
    folder = tmp_path_factory.mktemp("gstudy")
    path = _write(folder)
    result = run_study(path, workers=1, echo=None, command=COMMAND)
    assert len(result.results) == 2 and not result.n_failed
    specs = load_study(path).specs(False)
    runs, ids = collect(specs)
    by_case = {s.case: rid for s, rid in zip(specs, ids, strict=True)}
    out = folder / "study.report"
    return {"folder": folder, "study": path, "out": out, "ids": by_case,
            "json": (out / "report.json").read_bytes(), "md": (out / "report.md").read_text()}


def test_gravitating_summary_holds_the_occultations_and_the_report_its_table(grav_study):
    summaries = grav_study["folder"] / "summaries"
    grav = json.loads((summaries / f"{grav_study['ids']['gravity']}.json").read_text())
    plain = json.loads((summaries / f"{grav_study['ids']['plain']}.json").read_text())
    assert "occultation" not in plain, "no wakes to observe without self-gravity"
    occ = grav["occultation"]
    assert occ["elevations_deg"] == list(ELEVATIONS) and occ["azimuths"] == 24
    assert occ["geometric_optical_depth"]["mean"] == pytest.approx(0.2, rel=1e-9)
    assert occ["units"]["snapshot_orbits"] == "orbits"
    assert occ["wake_angle_from_radial_deg"]["units"] == "deg"
    # tau = 0.2 of spheres: face on, T lies between the monolayer's 1 - 0.2 and the thick
    # layer's exp(-0.2) = 0.819 (docs/observe.md), within 1 % errors of the largest of
    # 24 views
    face_on = occ["asymmetry"][-1]["peak_transmission"]["mean"]
    assert 0.79 < face_on < 0.83, face_on
    assert len(json.dumps(grav)) < 12_000, "summaries stay small"
    report = json.loads(grav_study["json"])
    table = report["against_cassini"]
    assert set(table["cases"]) == {"plain", "gravity"}
    assert table["cases"]["plain"]["verdict"] == "no wakes (no self-gravity)"
    entry = table["cases"]["gravity"]
    assert entry["seeds_measured"] == 1 and entry["gravity"] is True
    # no wake: the bar model's parameters are not averaged, the occultation's are
    assert entry["seeds_with_wake"] == 0 and entry["height_over_width"] is None
    assert entry["wake_angle_from_radial_deg"] is None
    assert entry["geometric_optical_depth"]["mean"] == pytest.approx(0.2, rel=1e-9)
    # no wake forms in 0.2 orbit from a random start (analyze's verdict)
    assert entry["verdict"] == "no significant wake"
    assert table["published"]["A_height_over_width"]["low"] == 0.15
    md = grav_study["md"]
    assert "## Against Cassini" in md and "Colwell et al. 2006" in md
    q = markdown._pm(entry["toomre_Q_mass"])
    row = (f"| gravity | 0 | kind monodisperse, radius 1.0 | none | 1 (0 with a wake) | {q} "
           "| no wake |")
    assert row in md
    assert "**no significant wake** |" in md and "**no wakes (no self-gravity)** |" in md


def test_report_only_gives_the_same_report(grav_study, tmp_path):
    path = _write(tmp_path / "copy")
    shutil.copytree(grav_study["folder"] / "summaries", tmp_path / "copy" / "summaries")
    run_study(path, report_only=True, echo=None, command=COMMAND)
    out = tmp_path / "copy" / "study.report"
    assert (out / "report.json").read_bytes() == grav_study["json"]
    assert (out / "report.md").read_text() == grav_study["md"]


def test_a_summary_without_a_window_snapshot_is_warned_about(grav_study, tmp_path):
    """A run none of whose snapshots lies in its equilibrium window (its occultations are
    from the last snapshot, before the window): its summary says so and the report warns;
    the summaries of runs with window snapshots do not carry the key."""
    path = _write(tmp_path / "late")
    summaries = tmp_path / "late" / "summaries"
    shutil.copytree(grav_study["folder"] / "summaries", summaries)
    assert not any("no_snapshot_in_window" in json.loads(f.read_text())
                   for f in summaries.iterdir())
    rid = grav_study["ids"]["gravity"]
    summary = json.loads((summaries / f"{rid}.json").read_text())
    summary["no_snapshot_in_window"] = True
    (summaries / f"{rid}.json").write_text(json.dumps(summary))
    run_study(path, report_only=True, echo=None, command=COMMAND)
    report = json.loads((tmp_path / "late" / "study.report" / "report.json").read_text())
    late = [w for w in report["warnings"] if "no snapshot lies in its equilibrium window" in w]
    assert len(late) == 1 and f"(run {rid})" in late[0]


def _with_edited_summary(grav_study, folder: Path, edit):
    """A copy of the tiny study in ``folder`` whose gravitating run's summary is the
    original after ``edit`` (a function changing a summary in place): the study file, the
    summaries folder, the run's id, the original summary and the edited one."""
    path = _write(folder)
    summaries = folder / "summaries"
    shutil.copytree(grav_study["folder"] / "summaries", summaries)
    rid = grav_study["ids"]["gravity"]
    full = json.loads((summaries / f"{rid}.json").read_text())
    old = copy.deepcopy(full)
    edit(old)
    (summaries / f"{rid}.json").write_text(json.dumps(old))
    return path, summaries, rid, full, old


def test_old_summary_renders_and_is_completed_from_its_run_file(grav_study, tmp_path):
    """A gravitating summary without ``occultation`` (an older ringsim's): the report says
    "not measured"; with the finished run file the study adds the occultations, keeps the
    summary's cost and gives the report of the full summaries."""
    path, summaries, rid, full, old = _with_edited_summary(
        grav_study, tmp_path / "old", lambda old: (
            old.pop("occultation"),
            old.update(cost={"cpu_time_s": 123.0, "run_wall_time_s": 45.0})))
    run_study(path, report_only=True, echo=None, command=COMMAND)
    out = tmp_path / "old" / "study.report"
    report = json.loads((out / "report.json").read_text())
    entry = report["against_cassini"]["cases"]["gravity"]
    assert entry["verdict"] == "not measured" and entry["height_over_width"] is None
    assert "| not measured |" in (out / "report.md").read_text()
    shutil.copytree(grav_study["out"] / "runs", out / "runs")
    result = run_study(path, workers=1, echo=None, command=COMMAND)
    assert [(r.run_id, r.action, r.status) for r in result.results] == \
        [(rid, "reuse", "finished")]
    done = json.loads((summaries / f"{rid}.json").read_text())
    assert done.pop("cost") == old["cost"]
    full.pop("cost")
    assert done == full
    assert (out / "report.json").read_bytes() == grav_study["json"]


def test_summary_without_occultation_keeps_its_format():
    """Old summaries load: the format is unchanged and the field optional."""
    assert SUMMARY_FORMAT == "ringsim study summary 1"
    assert cassini.lacks_occultation(_summary(occultation=False))
    assert not cassini.lacks_occultation(_summary(gravity=False))


def test_bundled_selfgravity_quick_report_comes_back_from_its_summaries(tmp_path):
    """studies/kappa-selfgravity: --report-only rewrites the committed quick report, with
    its "Against Cassini" section, from the committed summaries (but for the version)."""
    study = ROOT / "studies" / "kappa-selfgravity" / "study.yaml"
    committed = study.parent / "study.quick.report"
    run_study(study, out=tmp_path, quick=True, report_only=True, echo=None,
              command="ringsim study studies/kappa-selfgravity/study.yaml --quick")
    old = json.loads((committed / "report.json").read_text())
    new = json.loads((tmp_path / "report.json").read_text())
    assert new.pop("ringsim_version") == ringsim.__version__
    version = old.pop("ringsim_version")
    assert new == old and "against_cassini" in new
    assert (tmp_path / "report.md").read_text() == (committed / "report.md").read_text(
        ).replace(f"ringsim {version} ", f"ringsim {ringsim.__version__} ")



def test_a_vertical_view_has_no_peak_azimuth():
    from ringsim.study.cassini import _asymmetry

    views = [{"elevation_deg": b, "azimuth_deg": a, "normal_optical_depth": 0.5 + 0.01 * a / 45,
              "normal_optical_depth_stderr": 0.01, "transmission": 0.6 - 0.01 * a / 45,
              "transmission_stderr": 0.005} for b in (10.0, 90.0) for a in (0.0, 45.0, 90.0)]
    assert _asymmetry(views, 10.0)["peak_transmission_azimuth_deg"] == 0.0
    assert math.isnan(_asymmetry(views, 90.0)["peak_transmission_azimuth_deg"])


def test_gravitating_summary_keeps_toomre_q_of_the_window_by_mass(grav_study):
    """The summary's ``gravity`` holds analyze's Toomre Q from the mass-weighted sigma_x of
    the window's snapshots: here recomputed by hand from the run file's snapshots,
    sigma_x^2 = sum m (v_x - <v_x>_m)^2 / sum m (the shear flow is azimuthal, so v_x is
    the velocity relative to it), Q = sigma_x Omega / (3.36 G Sigma) with Sigma = M / (Lx
    Ly), averaged over the snapshots; the report gives it per case and the column."""
    from ringsim.analysis.observe import window_snapshots
    from ringsim.store.runfile import open_run

    rid = grav_study["ids"]["gravity"]
    summary = json.loads((grav_study["folder"] / "summaries" / f"{rid}.json").read_text())
    gravity = summary["gravity"]
    assert set(gravity) == set(cassini.GRAVITY)
    assert gravity["toomre_Q_mass"]["units"] == "dimensionless"
    assert gravity["lambda_cr"]["units"] == "m"
    run = open_run(grav_study["out"] / "runs" / f"{rid}.h5")
    Omega = run.scenario.orbital_frequency
    Lx, Ly = float(run.attrs["Lx"]), float(run.attrs["Ly"])
    G = 6.6743e-11
    qs = []
    for i in window_snapshots(run)[0]:
        snap = run.snapshot(i)
        m, vx = np.asarray(snap["mass"]), np.asarray(snap["vx"])
        mean = np.sum(m * vx) / np.sum(m)
        sigma_x = math.sqrt(np.sum(m * (vx - mean) ** 2) / np.sum(m))
        qs.append(sigma_x * Omega / (3.36 * G * np.sum(m) / (Lx * Ly)))
    assert gravity["toomre_Q_mass"]["mean"] == pytest.approx(np.mean(qs), rel=1e-6)
    eq = ringsim.equilibrium(run)
    assert gravity == {key: dict(eq[key]) for key in cassini.GRAVITY}
    assert "gravity" not in json.loads((grav_study["folder"] / "summaries" /
                                        f"{grav_study['ids']['plain']}.json").read_text())
    entry = json.loads(grav_study["json"])["against_cassini"]["cases"]["gravity"]
    assert entry["toomre_Q_mass"]["mean"] == gravity["toomre_Q_mass"]["mean"]
    assert entry["seeds_with_gravity"] == entry["n_seeds"] == 1
    assert "| Toomre Q (mass-weighted σ_x) |" in grav_study["md"]


def test_summary_without_gravity_is_completed_keeping_its_occultation(grav_study, tmp_path):
    """A gravitating summary with ``occultation`` but without ``gravity`` (made before
    summaries kept it) is completed from its run file with its occultation kept where it
    observed the window's snapshots (a marked number survives), and observed again where
    its snapshots are not the window's; the report without ``gravity`` has no Q column."""
    path, summaries, rid, full, _ = _with_edited_summary(
        grav_study, tmp_path / "nograv", lambda old: (
            old.pop("gravity"),
            old["occultation"]["geometric_optical_depth"].update(mean=0.123)))
    run_study(path, report_only=True, echo=None, command=COMMAND)
    out = tmp_path / "nograv" / "study.report"
    assert "Toomre Q" not in (out / "report.md").read_text()
    shutil.copytree(grav_study["out"] / "runs", out / "runs")
    run_study(path, workers=1, echo=None, command=COMMAND)
    done = json.loads((summaries / f"{rid}.json").read_text())
    assert done["gravity"] == full["gravity"]
    assert done["occultation"]["geometric_optical_depth"]["mean"] == 0.123
    del done["gravity"]
    done["occultation"]["snapshot_orbits"] = [-1.0]
    (summaries / f"{rid}.json").write_text(json.dumps(done))
    run_study(path, workers=1, echo=None, command=COMMAND)
    again = json.loads((summaries / f"{rid}.json").read_text())
    assert again["occultation"] == full["occultation"]


@pytest.mark.parametrize("how", ["wake verdict changed", "resummarise"])
def test_an_occultation_is_observed_anew_where_it_may_differ(grav_study, tmp_path, how):
    """A stored occultation is not kept where the wake verdict it was made with differs
    from today's (a summary completed to add ``gravity``), nor with ``--resummarise``
    (today's analysis throughout): a number planted in it is gone afterwards."""
    def edit(old):
        occ = old["occultation"]
        occ["geometric_optical_depth"]["mean"] = 0.123
        if how == "wake verdict changed":
            occ["wake_significant"] = not occ["wake_significant"]
            del old["gravity"]

    path, summaries, rid, full, _ = _with_edited_summary(grav_study, tmp_path / "anew", edit)
    shutil.copytree(grav_study["out"] / "runs", tmp_path / "anew" / "study.report" / "runs")
    run_study(path, workers=1, echo=None, command=COMMAND,
              resummarise=how == "resummarise")
    done = json.loads((summaries / f"{rid}.json").read_text())
    assert done["occultation"] == full["occultation"]
    assert done["gravity"] == full["gravity"]


def test_toomre_cell_names_the_seeds_it_is_of():
    """The mass-weighted Q of a case is over the seeds whose summaries hold ``gravity``;
    the cell says how many of the case's seeds that is where not all."""
    entry = {"gravity": True, "toomre_Q_mass": {"mean": 3.04, "stderr": 0.038},
             "seeds_with_gravity": 2, "n_seeds": 3}
    assert markdown._toomre_cell(entry) == "3.04 ± 0.038 (2 of 3 seeds)"
    assert markdown._toomre_cell({**entry, "seeds_with_gravity": 3}) == "3.04 ± 0.038"
    assert markdown._toomre_cell({"gravity": True}) == "not measured"
    assert markdown._toomre_cell({"gravity": False}) == "-"

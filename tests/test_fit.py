"""`ringsim fit`: recovery of known restitution laws from synthetic data, honest error bars,
model ranking by AIC, bad CSVs, and a restitution section that a scenario accepts."""

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from ringsim.analysis.fit import RestitutionData, fit_model, read_data
from ringsim.cli import main
from ringsim.config.scenario import scenario_from_dict
from ringsim.physics import restitution as rs
from ringsim.testing import hatzes_like_csv, write_hatzes_like

ROOT = Path(__file__).resolve().parent.parent
RADII = np.array([0.025, 0.05, 0.10, 0.20])  # [m] the radii of Hatzes et al. (1988)
MASSES = np.array([0.03, 0.06, 0.5, 2.0])    # [kg] varied independently of the radius
TRUTH = {"xi0": 0.2, "p": 0.6, "kappa": 0.08}  # not the optimizer's start values


def dilley_grid(speeds: np.ndarray, truth=TRUTH):
    """(v [m/s], R_bar [m], M_bar [kg], epsilon) on speeds x RADII x MASSES."""
    v, r, m = (a.ravel() for a in np.meshgrid(speeds, RADII, MASSES, indexing="ij"))
    return v, r, m, rs.dilley_epsilon(v, r, m, **truth)


def write_csv(path: Path, columns: dict) -> Path:
    names = list(columns)
    rows = zip(*(np.broadcast_to(columns[n], np.shape(columns[names[0]])) for n in names),
               strict=True)
    lines = [",".join(names)] + [",".join(repr(float(x)) for x in row) for row in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def noisy_dilley(rng, speeds, sigma=0.02):
    v, r, m, eps = dilley_grid(speeds)
    measured = eps + rng.normal(0.0, sigma, eps.size)
    return RestitutionData(v=v, R_bar=r, M_bar=m, epsilon=measured,
                           sigma=np.full(eps.size, sigma)), eps


def test_noise_free_dilley_data_give_the_true_parameters(tmp_path):
    v, r, m, eps = dilley_grid(np.geomspace(1.5e-3, 3e-2, 10))
    data = read_data(write_csv(tmp_path / "d.csv", {"v_m_s": v, "R_bar_m": r,
                                                    "M_bar_kg": m, "epsilon": eps}))
    fit = fit_model(data, "dilley")
    assert fit["success"] and fit["n_points"] == 160
    for name, value in TRUTH.items():
        assert fit["parameters"][name]["value"] == pytest.approx(value, rel=1e-6), name
        assert fit["parameters"][name]["fixed"] is False
    assert fit["chi2"] < 1e-20, "noise-free data are fitted exactly"
    assert fit["sigma_source"].startswith("none")


def test_noisy_dilley_fit_is_within_three_standard_errors():
    rng = np.random.default_rng(42)
    data, _ = noisy_dilley(rng, np.geomspace(1.5e-3, 3e-2, 25))  # 400 points
    fit = fit_model(data, "dilley")
    for name, value in TRUTH.items():
        entry = fit["parameters"][name]
        assert abs(entry["value"] - value) < 3 * entry["stderr"], \
            f"{name} = {entry['value']} +- {entry['stderr']} misses the truth {value}"
        assert entry["stderr"] < 0.1 * abs(value), f"{name} is constrained"
    dof = fit["n_points"] - 3
    assert abs(fit["reduced_chi2"] - 1.0) < 4 * np.sqrt(2.0 / dof), "chi2 matches sigma"
    assert fit["sigma_source"] == "sigma column"


def test_xi0_error_bar_covers_the_truth_about_68_percent_of_the_time():
    rng = np.random.default_rng(2024)
    speeds = np.geomspace(1.5e-3, 3e-2, 6)  # 96 points per replicate
    hits = []
    for _ in range(50):
        data, _ = noisy_dilley(rng, speeds)
        xi0 = fit_model(data, "dilley")["parameters"]["xi0"]
        hits.append(abs(xi0["value"] - TRUTH["xi0"]) < xi0["stderr"])
    coverage = np.mean(hits)
    assert 0.55 <= coverage <= 0.85, f"1-sigma coverage of xi0 is {coverage:.2f}, not ~0.68"


def test_unit_weights_scale_the_covariance_by_the_reduced_chi2():
    """Without sigma the error bars come from the scatter: about the same as with sigma."""
    rng = np.random.default_rng(7)
    data, _ = noisy_dilley(rng, np.geomspace(1.5e-3, 3e-2, 25))
    with_sigma = fit_model(data, "dilley")
    without = fit_model(RestitutionData(v=data.v, R_bar=data.R_bar, M_bar=data.M_bar,
                                        epsilon=data.epsilon), "dilley")
    for name in TRUTH:
        a, b = with_sigma["parameters"][name], without["parameters"][name]
        assert a["value"] == pytest.approx(b["value"], rel=1e-6), "same weights, same fit"
        ratio = b["stderr"] / a["stderr"]
        assert ratio == pytest.approx(np.sqrt(with_sigma["reduced_chi2"]), rel=1e-4)


def test_bridges_data_give_bridges_parameters():
    v = np.geomspace(5e-5, 3e-2, 40)  # below and above v_c
    eps = rs.bridges_epsilon(v, v_c=1.5e-4, exponent=0.3)
    fit = fit_model(RestitutionData(v=v, R_bar=None, M_bar=None, epsilon=eps), "bridges")
    assert fit["parameters"]["v_c"]["value"] == pytest.approx(1.5e-4, rel=1e-6)
    assert fit["parameters"]["exponent"]["value"] == pytest.approx(0.3, rel=1e-6)
    assert fit["units"]["v_c"] == "m/s"


@pytest.mark.parametrize("model, truth", [
    ("tabor", {"v_c": 0.0809e-2, "q": 0.371}),  # Dilley's Fig. 1a curve c
    ("andrews", {"v_c": 2.0e-4}),
    ("constant", {"epsilon": 0.5}),
])
def test_critical_speed_and_constant_laws_are_recovered(model, truth):
    v = np.geomspace(1e-4, 3e-2, 30)
    eps = {"tabor": rs.tabor_epsilon, "andrews": rs.andrews_epsilon,
           "constant": rs.constant_epsilon}[model](v, **truth)
    fit = fit_model(RestitutionData(v=v, R_bar=None, M_bar=None, epsilon=eps), model)
    for name, value in truth.items():
        assert fit["parameters"][name]["value"] == pytest.approx(value, rel=1e-6), name


def test_kappa_is_fixed_when_the_mass_never_changes(tmp_path):
    """Spheres against a brick on one pendulum (Hatzes et al. 1988): R2 = M2 = inf."""
    v = np.tile(np.geomspace(1e-3, 2e-2, 8), 4)
    r1 = np.repeat(RADII, 8)
    eps = rs.dilley_epsilon(v, r1, 0.06, xi0=0.16, p=0.65)
    path = write_csv(tmp_path / "brick.csv", {"v_m_s": v, "R1_m": r1, "R2_m": np.inf,
                                              "M1_kg": 0.06, "M2_kg": np.inf, "epsilon": eps})
    data = read_data(path)
    np.testing.assert_array_equal(data.R_bar, r1)  # a wall leaves the sphere's radius
    fit = fit_model(data, "dilley")
    kappa = fit["parameters"]["kappa"]
    assert kappa == {"value": 0.0, "stderr": None, "fixed": True}
    assert "kappa fixed" in fit["note"] and fit["n_free_parameters"] == 2
    assert fit["parameters"]["xi0"]["value"] == pytest.approx(0.16, rel=1e-6)
    assert fit["parameters"]["p"]["value"] == pytest.approx(0.65, rel=1e-6)


HATZES_LIKE = ROOT / "docs" / "data" / "hatzes_like.csv"


def test_synthetic_hatzes_like_file_gives_dilleys_fit():
    """docs/data/hatzes_like.csv was made from xi0 = 0.16, p = 0.65 with noise."""
    fit = fit_model(read_data(HATZES_LIKE), "dilley")
    for name, value in (("xi0", 0.16), ("p", 0.65)):
        entry = fit["parameters"][name]
        assert abs(entry["value"] - value) < 3 * entry["stderr"], name
    assert fit["parameters"]["kappa"]["fixed"]


def test_synthetic_hatzes_like_file_is_regenerated_byte_for_byte(tmp_path):
    """The committed example is what its generator writes (same seed, same text), and the
    generator's rows are Dilley's law: an unseeded change of either shows here."""
    written = write_hatzes_like(tmp_path / "sub" / "hatzes_like.csv")
    assert written.read_bytes() == HATZES_LIKE.read_bytes()
    assert hatzes_like_csv() == HATZES_LIKE.read_text()
    data = read_data(written)
    assert len(data.v) == 96     # 4 radii x 12 speeds x 2 repeats
    exact = rs.dilley_epsilon(data.v, data.R_bar, data.M_bar)
    # the noise's sigma is at most 0.04 (0.01 + 0.03 (1 - eps)); 5 sigma bounds every row
    assert np.all(np.abs(data.epsilon - exact) <= 5 * data.sigma)


@pytest.mark.parametrize("true_model", ["dilley", "bridges"])
def test_model_all_ranks_the_true_model_first(tmp_path, true_model):
    rng = np.random.default_rng(11)
    v, r, m, eps = dilley_grid(np.geomspace(1.5e-3, 3e-2, 6))
    if true_model == "bridges":
        eps = rs.bridges_epsilon(v, v_c=1e-4, exponent=0.25)
    eps = np.clip(eps + rng.normal(0.0, 0.005, eps.size), 0.0, 1.0)
    path = write_csv(tmp_path / "d.csv", {"v_m_s": v, "R_bar_m": r, "M_bar_kg": m,
                                          "epsilon": eps, "sigma": 0.005})
    out = tmp_path / "fits.json"
    assert main(["fit", str(path), "--model", "all", "--json", str(out)]) == 0
    fits = json.loads(out.read_text())
    assert [f["model"] for f in fits][0] == true_model
    assert sorted(f["model"] for f in fits) == ["andrews", "bridges", "constant", "dilley",
                                                 "tabor"]
    assert [f["aic"] for f in fits] == sorted(f["aic"] for f in fits)
    for f in fits:
        assert {"model", "parameters", "chi2", "reduced_chi2", "aic", "n_points"} <= set(f)
        assert f["n_points"] == eps.size
        assert all(set(p) >= {"value", "stderr"} for p in f["parameters"].values())


def test_cli_writes_json_plot_and_a_restitution_section_a_scenario_accepts(tmp_path, capsys):
    rng = np.random.default_rng(5)
    data, _ = noisy_dilley(rng, np.geomspace(1.5e-3, 3e-2, 4))
    path = write_csv(tmp_path / "lab.csv", {"v_m_s": data.v, "R_bar_m": data.R_bar,
                                            "M_bar_kg": data.M_bar, "epsilon": data.epsilon,
                                            "sigma": data.sigma})
    out_json, png, section = tmp_path / "fit.json", tmp_path / "fit.png", tmp_path / "r.yaml"
    assert main(["fit", str(path), "--json", str(out_json), "--plot", str(png),
                 "--write-restitution", str(section)]) == 0
    fit = json.loads(out_json.read_text())
    assert fit["model"] == "dilley" and set(fit["parameters"]) == {"xi0", "p", "kappa"}
    assert png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size > 20_000
    assert "xi0 = " in capsys.readouterr().out
    restitution = yaml.safe_load(section.read_text())["restitution"]
    scenario = scenario_from_dict({
        "name": "fitted", "seed": 1, "planet": {"Omega": 2.0e-4},
        "particles": {"size_distribution": {"kind": "monodisperse", "radius": 1.0}},
        "restitution": restitution})
    for name in ("xi0", "p", "kappa"):
        assert getattr(scenario.restitution, name) == fit["parameters"][name]["value"]


def test_write_restitution_takes_the_lowest_aic(tmp_path):
    v = np.geomspace(5e-5, 3e-2, 40)
    eps = rs.bridges_epsilon(v, v_c=1.5e-4, exponent=0.3)
    path = write_csv(tmp_path / "b.csv", {"v_m_s": v, "R_bar_m": 0.025, "M_bar_kg": 0.06,
                                          "epsilon": eps})
    section = tmp_path / "r.yaml"
    assert main(["fit", str(path), "--model", "all", "--write-restitution", str(section)]) == 0
    restitution = yaml.safe_load(section.read_text())["restitution"]
    assert restitution["model"] == "bridges"
    assert restitution["v_c"] == pytest.approx(1.5e-4, rel=1e-6)


GOOD = "v_m_s,R_bar_m,M_bar_kg,epsilon\n0.001,0.025,0.06,0.9\n0.002,0.025,0.06,0.8\n"


@pytest.mark.parametrize("text, column", [
    ("v_m_s,R_bar_m,M_bar_kg\n0.001,0.025,0.06\n", "epsilon"),              # missing
    (GOOD.replace("epsilon", "epsilon,colour") .replace("0.9\n", "0.9,red\n")
     .replace("0.8\n", "0.8,blue\n"), "colour"),                              # unknown
    (GOOD.replace("0.002,", "fast,"), "v_m_s"),                               # not a number
    (GOOD.replace(",0.8\n", ",1.2\n"), "epsilon"),                            # eps > 1
    (GOOD.replace(",0.9\n", ",-0.1\n"), "epsilon"),                           # eps < 0
    (GOOD.replace("R_bar_m", "R_bar_cm"), "R_bar_cm"),                        # wrong unit
    (GOOD.replace(",epsilon", ",epsilon,sigma").replace("0.9\n", "0.9,0\n")
     .replace("0.8\n", "0.8,0.01\n"), "sigma"),                               # sigma = 0
    ("v_m_s,epsilon\n0.001,0.9\n", "R_bar_m"),                                # dilley: sizes
    ("v_m_s,R1_m,M_bar_kg,epsilon\n0.001,0.025,0.06,0.9\n", "R2_m"),         # half a pair
    (GOOD.replace("0.025,0.06,0.9", "inf,0.06,0.9"), "R_bar_m"),              # inf R_bar
])
def test_bad_csv_is_bad_input_naming_file_and_column(tmp_path, capsys, text, column):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    out = tmp_path / "fit.json"
    assert main(["fit", str(path), "--json", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "bad.csv" in err[0] and column in err[0] and "Traceback" not in err[0]
    assert not out.exists(), "nothing written"


def test_bad_row_is_named_by_its_line(tmp_path, capsys):
    path = tmp_path / "bad.csv"
    path.write_text("# lab run 3\n" + GOOD + "0.004,0.025,0.06,1.5\n")
    assert main(["fit", str(path)]) == 2
    assert "line 5" in capsys.readouterr().err


def test_unknown_model_and_missing_file_are_bad_input(tmp_path, capsys):
    path = tmp_path / "good.csv"
    path.write_text(GOOD)
    assert main(["fit", str(path), "--model", "dilly"]) == 2
    assert "--model" in capsys.readouterr().err
    assert main(["fit", str(tmp_path / "missing.csv")]) == 2
    assert "missing.csv" in capsys.readouterr().err

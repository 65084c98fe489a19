"""`ringsim epsilon`: the paper's curves on stdout, as JSON and as a figure."""

import json

import numpy as np

from ringsim.cli import main
from ringsim.physics import restitution as rs


def test_epsilon_command_writes_figure_and_json(tmp_path, capsys):
    png, out = tmp_path / "eps.png", tmp_path / "eps.json"
    assert main(["epsilon", "--plot", str(png), "--json", str(out)]) == 0
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"
    curves = json.loads(out.read_text())["curves"]
    panels = {c["panel"] for c in curves}
    assert panels == {"fig1", "fig5_kappa0", "fig5_kappa0.1", "plastic"}
    ref = next(c for c in curves if c["panel"] == "fig1" and c["label"] == "R = 2.5 cm")
    v = np.array(ref["v"])
    assert v.min() == 1e-4 and abs(v.max() - 2e-2) < 1e-15, "0.01-2 cm/s"
    np.testing.assert_allclose(ref["epsilon"], rs.dilley_epsilon(v, 0.025, 0.06), rtol=1e-15)
    assert "R1 = 0.25 cm" in capsys.readouterr().out


def test_epsilon_rejects_non_png(tmp_path, capsys):
    assert main(["epsilon", "--plot", str(tmp_path / "eps.pdf")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--plot" in err[0]
    assert not (tmp_path / "eps.pdf").exists()


def test_unknown_command_is_bad_input(capsys):
    assert main(["frobnicate"]) == 2
    assert "Traceback" not in capsys.readouterr().err

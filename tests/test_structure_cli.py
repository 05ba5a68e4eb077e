"""``romams modal`` command: JSON contract, design parsing, errors, plots."""

import json

import pytest
from typer.testing import CliRunner

from romams.cli import app

runner = CliRunner()
DESIGN = "x1=0.3,x2=0.5,x3=0.7,x4=0.05,x5=1.0,x6=1.0,x7=0.8"


def test_modal_baseline_json_contract():
    res = runner.invoke(app, ["modal", "--wing", "cropped-delta", "--baseline", "--modes", "3", "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.output)
    assert {"frequencies_hz", "mass_kg", "n_fe_nodes"} <= set(out)
    assert len(out["frequencies_hz"]) == 3
    assert out["frequencies_hz"] == pytest.approx([26.7, 88.2, 131.8], rel=0.03)
    assert out["mass_kg"] == pytest.approx(0.24, rel=0.02)
    assert out["n_fe_nodes"] > 100


def test_modal_design_and_plot(tmp_path):
    res = runner.invoke(app, ["modal", "--design", DESIGN, "--json", "--plot", str(tmp_path)])
    assert res.exit_code == 0, res.output
    out = json.loads(res.output)
    assert out["design"]["x4"] == 0.05 and len(out["frequencies_hz"]) == 4
    # lumped mass + beam on a thinner plate: heavier than 0.8 * 0.24 kg + 0.05 kg
    assert out["mass_kg"] > 0.8 * 0.24 + 0.05
    png = tmp_path / "modes.png"
    assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_modal_design_in_repeated_options_equals_one_list():
    """``--design x1=..,x2=..`` and ``--design x1=.. --design x2=..`` (and mixed) are the same design."""
    outs = [json.loads(runner.invoke(app, ["modal", *args, "--json", "--modes", "2"]).output) for args in (
        ["--design", DESIGN],
        [a for item in DESIGN.split(",") for a in ("--design", item)],
        ["--design", "x1=0.3,x2=0.5,x3=0.7", "--design", "x4=0.05,x5=1.0,x6=1.0,x7=0.8"])]
    assert outs[0] == outs[1] == outs[2] and outs[0]["design"]["x7"] == 0.8


def test_modal_goland_json():
    res = runner.invoke(app, ["modal", "--wing", "goland", "--json", "--modes", "2"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.output)
    assert out["frequencies_hz"] == pytest.approx([7.66, 15.24], rel=0.01)


@pytest.mark.parametrize(
    ("args", "text"),
    [
        (["--design", DESIGN.replace("x1=0.3", "x1=0.9")], "x1"),
        (["--design", "x1=0.3"], "missing"),
        (["--design", DESIGN + ",x9=1"], "unknown"),
        (["--design", "x1"], "NAME=VALUE"),
        (["--design", DESIGN, "--design", "x1=0.4"], "x1: given twice"),
        (["--wing", "no-such-wing"], "unknown template"),
    ],
)
def test_modal_bad_input_exits_with_usage_error(args, text, tmp_path, monkeypatch):
    from romams.settings import get_settings

    monkeypatch.setenv("ROMAMS_DATA_DIR", str(tmp_path))  # an unknown wing is looked up in a fresh, empty store
    monkeypatch.delenv("ROMAMS_DATABASE_URL", raising=False)
    get_settings.cache_clear()
    try:
        res = runner.invoke(app, ["modal", *args])
    finally:
        get_settings.cache_clear()
    assert res.exit_code == 2
    assert text in res.output


def test_modal_text_is_a_table_of_four_significant_figures():
    res = runner.invoke(app, ["modal", "--wing", "cropped-delta", "--baseline", "--modes", "3"])
    assert res.exit_code == 0, res.output
    rows = [ln.split() for ln in res.stdout.splitlines() if ln.split()[:1] in (["1"], ["2"], ["3"])]
    assert [r[0] for r in rows] == ["1", "2", "3"] and "f (Hz)" in res.stdout and "kg" in res.stdout
    assert float(rows[0][1]) == pytest.approx(26.7, rel=0.02)  # the measured first bending mode
    assert all(len(r[1].replace(".", "").lstrip("0")) == 4 for r in rows)

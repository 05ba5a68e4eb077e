"""V-g / envelope plots render to valid PNG/SVG and state the damping sign convention."""

from __future__ import annotations

import numpy as np
import pytest

from romams.plots.flutter import envelope_figure, envelope_plot, vg_figure, vg_plot
from romams_core.envelope import safe_envelope
from romams_core.flutter import flutter_analysis
from romams_core.typical_section import TypicalSection, jones_discrete, modes


@pytest.fixture(scope="module")
def result():
    ts = TypicalSection()
    w, _ = modes(ts)
    return flutter_analysis(w, jones_discrete(ts, 0.05), ts.c_ref, 0.3, sweep="constant-speed")


def test_vg_plot_png_svg(result):
    png = vg_plot(result, "png")
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 5000
    svg = vg_plot(result, "svg").decode()
    assert "<svg" in svg
    fig = vg_figure(result)
    ax_g, ax_f = fig.axes
    assert "g > 0: unstable" in ax_g.get_ylabel()
    assert "sqrt(2q/rho_ref)" in ax_f.get_xlabel()
    # two mode lines + flutter marker on the g panel, data identical to the result
    np.testing.assert_allclose(ax_g.lines[0].get_ydata(), result.g[:, 0])
    with pytest.raises(ValueError, match="fmt"):
        vg_plot(result, "jpg")


def test_envelope_plot():
    bench = safe_envelope([0.79, 0.87, 0.95], [16000.0, 15000.0, 14000.0])
    design = safe_envelope([0.79, 0.87, 0.95], [17000.0, 15500.0, 13000.0])
    fig = envelope_figure({"optimum": design}, benchmark=bench)
    ax = fig.axes[0]
    np.testing.assert_allclose(ax.lines[0].get_ydata(), bench.safe_altitude_m / 1000.0)
    np.testing.assert_allclose(ax.lines[1].get_ydata(), design.safe_altitude_m / 1000.0)
    assert envelope_plot([design], bench, "png")[:4] == b"\x89PNG"

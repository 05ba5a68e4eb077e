"""Flutter plots by the conventions of Nastran/ZAERO flutter output: V-g / V-f from q = 0 with the wind-off
frequencies, a zoomed damping panel, the TAS / EAS / q axis, the envelope against its constraint line with the
pass/fail colours of the envelope check, MAC on log10(1 - MAC), planform shape plots, and the plot cache."""

from __future__ import annotations

import math

import numpy as np
import pytest
from matplotlib.colors import to_rgba

from romams.plots.basis import REFERENCE_THRESHOLDS, log_residual, plot_basis_shapes, plot_mac_vs_basis_size
from romams.plots.cache import PlotCache, plot_key
from romams.plots.envelope import BENCHMARK_LABEL, FAIL_COLOR, FLUTTER_BOUNDARY_LABEL, PASS_COLOR
from romams.plots.flutter import envelope_figure, envelope_plot, vg_figure, vg_plot
from romams.plots.vg import G_ZOOM_WINDOW, axis_rho, speed_axis, vg_data
from romams_core.atmosphere import RHO_SEA_LEVEL
from romams_core.envelope import compare_envelopes, safe_envelope
from romams_core.flutter import flutter_analysis
from romams_core.flutter.curves import CROSSING_POINTS
from romams_core.typical_section import TypicalSection, jones_discrete, modes

ZETA = 0.01
SWEEPS = ("constant-speed", "constant-density", "matched")


@pytest.fixture(scope="module")
def section():
    ts = TypicalSection()
    w, _ = modes(ts)
    return ts, np.asarray(w, float), jones_discrete(ts, 0.05)


@pytest.fixture(scope="module")
def results(section):
    ts, w, aero = section
    return {s: flutter_analysis(w, aero, ts.c_ref, 0.3, sweep=s, zeta=ZETA) for s in SWEEPS}


@pytest.fixture(scope="module")
def result(results):
    return results["constant-speed"]


def test_vg_plot_png_svg(result):
    png = vg_plot(result, "png")
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 5000
    assert "<svg" in vg_plot(result, "svg").decode()
    ax_g, ax_zoom, ax_f = vg_figure(result).axes
    assert "g > 0: unstable" in ax_g.get_ylabel() and "Hz" in ax_f.get_ylabel()
    assert "sqrt(2q/rho_ref)" in ax_f.get_xlabel()
    np.testing.assert_allclose(ax_g.lines[0].get_ydata(), result.curves.g[:, 0], rtol=0, atol=0)
    with pytest.raises(ValueError, match="fmt"):
        vg_plot(result, "jpg")


@pytest.mark.parametrize("sweep", SWEEPS)
def test_vg_data_start_at_q0_with_the_wind_off_modes(results, section, sweep):
    """The curves start at q = 0 with the in-vacuo poles (omega_i, g = -2 zeta); the coarse V-g data of the
    result are a subset of them, unchanged; the legend lists the wind-off frequencies in Hz."""
    r, w = results[sweep], section[1]
    c = vg_data(r)
    assert c.q[0] == 0.0 and c.kind[0] == 0 and np.all(np.diff(c.q) >= 0)
    np.testing.assert_allclose(c.omega[0], w * math.sqrt(1 - ZETA**2), rtol=1e-14)
    np.testing.assert_allclose(c.g[0], -2 * ZETA, rtol=1e-14)
    coarse = c.kind == 1
    keep = np.isfinite(c.altitude[coarse]) if sweep == "matched" else np.ones(coarse.sum(), bool)
    np.testing.assert_array_equal(c.g[coarse][keep], r.g)  # bit-identical to the search's V-g data
    np.testing.assert_array_equal(c.q[coarse][keep], r.q)
    fig = vg_figure(r, axis="eas")
    assert fig.axes[0].lines[0].get_xdata()[0] == 0.0
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    for j, om in enumerate(w):
        assert f"mode {j + 1} (wind-off {om * math.sqrt(1 - ZETA**2) / (2 * math.pi):.4g} Hz)" in legend


def test_vg_refined_near_each_crossing(results):
    """The flutter point is on the curves (g = 0 to 1e-3) and every later sign change of g has the plot-only
    points inside its interval."""
    r = results["constant-density"]
    c = vg_data(r)
    j = r.flutter_mode - 1
    (i_f,) = np.flatnonzero(c.kind == 3)
    assert abs(c.g[i_f, j]) < 1e-3 and c.q[i_f] == pytest.approx(r.q_flutter_pa, rel=1e-12)
    extra = np.flatnonzero(c.kind == 4)
    assert extra.size >= CROSSING_POINTS
    unstable = c.g > 1e-9
    changes = np.flatnonzero(np.any(unstable[1:] != unstable[:-1], axis=1))
    later = [i for i in changes if c.q[i] > r.q_flutter_pa]
    assert later and all(c.kind[i] == 4 or c.kind[i + 1] == 4 for i in later)  # bracketed by refined points


def test_zoomed_damping_panel_and_hz_title(result):
    fig = vg_figure(result)
    ax_g, ax_zoom, _ = fig.axes
    lo, hi = ax_zoom.get_ylim()
    assert lo < 0 < hi and hi - lo <= 2.3 * G_ZOOM_WINDOW
    assert (hi - lo) < 0.5 * np.ptp(ax_g.get_ylim())  # zoomed: narrower than the full panel
    title = ax_g.get_title()
    f_f = result.omega_flutter_rad_s / (2 * math.pi)
    assert f"f_f = {f_f:.4g} Hz" in title and "rad/s" not in title


@pytest.mark.parametrize("sweep", SWEEPS)
def test_speed_axis_conversions(results, sweep):
    """EAS = TAS sqrt(rho / rho_0) and q = rho TAS^2 / 2 (to 1e-12) on every sweep; the figure draws them."""
    r = results[sweep]
    c = vg_data(r)
    tas, keep_t, _ = speed_axis(r, "tas")
    eas, keep_e, lab_e = speed_axis(r, "eas")
    q, _, lab_q = speed_axis(r, "q")
    rho = axis_rho(r, c)
    np.testing.assert_allclose(eas[keep_t], (tas * np.sqrt(rho / RHO_SEA_LEVEL))[keep_t], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(q[keep_t], (0.5 * rho * tas**2)[keep_t], rtol=1e-12, atol=1e-9)
    assert keep_e.all() and "EAS" in lab_e and "kPa" in lab_q
    np.testing.assert_allclose(vg_figure(r, axis="q").axes[0].lines[0].get_xdata(), q / 1e3, rtol=1e-15)
    x_f = vg_figure(r, axis="eas").axes[0].lines[-1].get_xdata()[0]  # the flutter star
    assert x_f == pytest.approx(r.v_eas_m_s, rel=1e-12)
    with pytest.raises(ValueError, match="axis"):
        speed_axis(r, "mach")


def _verdict_colors(fig, name):
    (sc,) = [c for c in fig.axes[0].collections if c.get_gid() == f"verdict:{name}"]
    return [tuple(c) for c in sc.get_facecolors()]


@pytest.mark.parametrize("design_qf, expect_ok", [((17000.0, 15500.0, 14500.0), True),
                                                   ((17000.0, 15500.0, 13000.0), False)])
def test_envelope_benchmark_line_and_pass_fail_colours(design_qf, expect_ok):
    machs = [0.79, 0.87, 0.95]
    bench = safe_envelope(machs, [16000.0, 15000.0, 14000.0])
    design = safe_envelope(machs, design_qf)
    comp = compare_envelopes(design, bench)
    assert comp.envelope_ok is expect_ok
    for fig in (envelope_figure({"d": design}, benchmark=bench),  # benchmark given
                envelope_figure({"d": design}, comparisons={"d": comp})):  # rebuilt from the stored margins
        ax = fig.axes[0]
        (line,) = [ln for ln in ax.lines if ln.get_label() == BENCHMARK_LABEL]
        np.testing.assert_allclose(line.get_ydata(), bench.safe_altitude_m / 1e3, rtol=1e-12)
        want = [to_rgba(PASS_COLOR if ok else FAIL_COLOR) for ok in comp.ok]
        assert _verdict_colors(fig, "d") == want
        assert any(f"envelope_ok = {expect_ok}" in t.get_text() for t in ax.get_legend().get_texts())
        # shading: green below the constraint line (pass side), red above (fail side)
        fills = {c.get_label(): c for c in ax.collections if c.get_label().endswith("benchmark")}
        assert to_rgba(PASS_COLOR, 0.12) == tuple(fills["pass side: safe altitude <= benchmark"].get_facecolor()[0])
        assert to_rgba(FAIL_COLOR, 0.10) == tuple(fills["fail side: safe altitude > benchmark"].get_facecolor()[0])
        lo, hi = ax.get_ylim()  # autoscaled to the data, not the 0-20 km range
        alts = np.concatenate([bench.safe_altitude_m, design.safe_altitude_m]) / 1e3
        assert lo < alts.min() and hi > alts.max() and hi - lo < 1.5 * np.ptp(alts) + 0.5
    assert envelope_plot([design], bench, "png")[:4] == b"\x89PNG"


def test_envelope_without_benchmark_draws_the_flutter_boundary():
    design = safe_envelope([0.79, 0.87], [17000.0, 15500.0])
    ax = envelope_figure({"d": design}).axes[0]
    (line,) = [ln for ln in ax.lines if ln.get_label() == FLUTTER_BOUNDARY_LABEL]
    np.testing.assert_allclose(line.get_ydata(), safe_envelope([0.79, 0.87], [17000.0, 15500.0], 1.0)
                               .safe_altitude_m / 1e3)
    assert np.all(line.get_ydata() < design.safe_altitude_m / 1e3)  # the margin lies between them


def test_mac_plot_on_log_residual_with_thresholds():
    mac = np.array([0.5, 0.9, 0.99, 0.999, 0.99999, 1.0])
    ax = plot_mac_vs_basis_size(mac, 0.999, 4).axes[0]
    np.testing.assert_allclose(ax.lines[0].get_ydata(), np.log10(np.maximum(1 - mac, 1e-16)), rtol=1e-14)
    assert "log10(1 - MAC)" in ax.get_ylabel()
    levels = {round(float(ln.get_ydata()[0]), 9) for ln in ax.lines[1:] if np.ptp(ln.get_ydata()) == 0}
    for t in [0.999] + [t for t, _ in REFERENCE_THRESHOLDS]:
        assert round(float(log_residual(np.array(t))), 9) in levels
    assert {0.98, 0.9999} <= {t for t, _ in REFERENCE_THRESHOLDS}


def test_basis_shapes_have_axes_colour_bar_root_tip_and_flow():
    from romams_core.mesh import standard_mesh
    from romams_core.wing import template

    mesh = standard_mesh(template("cropped-delta").planform)
    shapes = np.linalg.qr(np.random.default_rng(0).normal(size=(mesh.n_nodes, 3)))[0]
    fig = plot_basis_shapes(mesh, shapes, [3.0, 2.0, 1.0])
    panels = [a for a in fig.axes if a.get_title().startswith("basis")]
    bars = [a for a in fig.axes if a.get_label() == "<colorbar>"]
    assert len(panels) == 3 and len(bars) == 1 and "max|w|" in bars[0].get_ylabel()
    for ax in panels:
        assert "(m)" in ax.get_xlabel() and "(m)" in ax.get_ylabel()
        assert {t.get_gid() for t in ax.texts} >= {"root", "tip", "flow"}
        assert ax.get_ylim()[0] > ax.get_ylim()[1]  # chord axis inverted: leading edge at the top


def test_plot_cache_key_and_lru_bound():
    a = {"x": np.arange(3.0), "opt": "tas"}
    assert plot_key(a) == plot_key({"opt": "tas", "x": np.arange(3.0)})
    assert plot_key(a) != plot_key({"x": np.arange(3.0) + [0.0, 1e-12, 0.0], "opt": "tas"})
    assert plot_key(a) != plot_key({"x": np.arange(3.0), "opt": "eas"})
    cache = PlotCache(max_bytes=10)
    cache.put("a", b"12345")
    cache.put("b", b"1234")
    assert cache.get("a") == b"12345"  # a is now the most recent
    cache.put("c", b"123")
    assert cache.get("b") is None and cache.get("a") == b"12345" and cache.size_bytes <= 10
    assert cache.render("c", lambda: b"other") == b"123"

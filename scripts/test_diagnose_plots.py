#!/usr/bin/env python3
"""Self-test of diagnose_plots.py: the residual axes follow the data (the phase
shading must not force a residual axis up to 1.0 m/s, where 0.02 m/s residuals are flat
lines).
Run: /usr/bin/python3 scripts/test_diagnose_plots.py"""
import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import numpy as np  # noqa: E402

import diagnose_plots  # noqa: E402


def small_series(amplitude):
    t = np.arange(600.0, 900.0, 0.1)
    phase = np.where((t > 650) & (t < 700), "turn",
                     np.where((t > 800) & (t < 820), "speed change", "cruise"))
    eb = amplitude * np.sin(t / 7.0)
    nb = amplitude * np.cos(t / 11.0)
    return t, phase, eb, nb, 0.3 * eb, 0.3 * nb


class ResidualAxes(unittest.TestCase):
    def test_limits_follow_the_data(self):
        for amplitude in (0.02, 3.0):
            series = small_series(amplitude)
            report = {"noise_floor": {"rms_mps": 0.5 * amplitude}, "found": []}
            fig = diagnose_plots.residuals_figure(report, series)
            _, _, eb, nb, _, _ = series
            data = [(eb.min(), eb.max()), (nb.min(), nb.max()), (0.0, np.hypot(eb, nb).max())]
            for ax, (lo, hi) in zip(fig.axes, data):
                y0, y1 = ax.get_ylim()
                self.assertLessEqual(y0, lo, ax.get_ylabel())
                self.assertGreaterEqual(y1, hi, ax.get_ylabel())
                # No more than 25 % of the axis beyond the data (matplotlib's margins are 5 %).
                self.assertLess(y1 - y0, 1.25 * (hi - min(lo, 0.0) if ax is fig.axes[2] else hi - lo),
                                f"{ax.get_ylabel()} at amplitude {amplitude}: {y0}..{y1}")
            # The shading is there: one span per phase run on each axis.
            self.assertEqual(len(fig.axes[0].patches), 2)
            diagnose_plots.plt.close(fig)

    def test_spans_cover_the_runs(self):
        t = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
        mask = np.array([True, True, False, True, False])
        self.assertEqual(diagnose_plots.phase_spans(t, mask), [(0.0, 1.5), (2.5, 3.5)])

    def test_writes_the_png(self):
        with tempfile.TemporaryDirectory() as d:
            out = os.path.join(d, "r.png")
            diagnose_plots.plot_residuals({"found": []}, small_series(0.02), out)
            self.assertGreater(os.path.getsize(out), 1000)


if __name__ == "__main__":
    unittest.main()

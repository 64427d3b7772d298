#!/usr/bin/env python3
"""Self-test of nav_error_plot.py: known offsets give the known errors; axes carry units.
Run: /usr/bin/python3 scripts/test_nav_error_plot.py"""
import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import numpy as np  # noqa: E402

import nav_error_plot as nep  # noqa: E402

HEADER = "t_s,lat_deg,lon_deg,h_m,vE_mps,vN_mps,vU_mps,roll_deg,pitch_deg,yaw_deg\n"


def write(path, t, lat, lon, ve, vn):
    with open(path, "w") as f:
        f.write(HEADER)
        for k in range(len(t)):
            f.write(f"{t[k]:.6f},{lat[k]:.12f},{lon[k]:.12f},50,{ve[k]},{vn[k]},0,0,0,0\n")


class NavErrorPlot(unittest.TestCase):
    def test_known_offsets(self):
        with tempfile.TemporaryDirectory() as d:
            t = np.arange(600.0, 700.0, 0.5)
            lat = np.full_like(t, 40.0)
            lon = np.full_like(t, 116.0)
            zero = np.zeros_like(t)
            write(os.path.join(d, "truth.csv"), t, lat, lon, zero, zero)
            # 1e-4 deg north ~ 11.1 m at 40 deg; velocity 0.3 east, 0.4 north -> 0.5 m/s.
            write(os.path.join(d, "before.csv"), t, lat + 1e-4, lon, zero + 0.3, zero + 0.4)
            # 1e-4 deg east ~ 8.5 m at 40 deg.
            write(os.path.join(d, "after.csv"), t, lat, lon + 1e-4, zero, zero)
            ref, name = nep.reference(d)
            self.assertEqual(name, "truth")
            tb, dp, dv = nep.errors(nep.read_solution(os.path.join(d, "before.csv")), ref)
            self.assertAlmostEqual(dp[0], 11.10, delta=0.02)
            self.assertAlmostEqual(dv[0], 0.5, places=9)
            _, dp_after, _ = nep.errors(nep.read_solution(os.path.join(d, "after.csv")), ref)
            self.assertAlmostEqual(dp_after[0], 8.53, delta=0.02)
            out = os.path.join(d, "f.png")
            self.assertEqual(nep.main(["--data", d, "--before", os.path.join(d, "before.csv"),
                                       "--after", os.path.join(d, "after.csv"), "--out", out]), 0)
            self.assertGreater(os.path.getsize(out), 1000)
            fig = nep.figure(name, (tb, dp, dv), (tb, dp_after, dv * 0), "b", "a")
            for ax in fig.axes[:2]:
                self.assertRegex(ax.get_ylabel(), r"\((m|m/s)\)$")
            self.assertEqual(fig.axes[1].get_xlabel(), "time (s)")

    def test_bad_file_is_named(self):
        with tempfile.TemporaryDirectory() as d:
            bad = os.path.join(d, "bad.csv")
            with open(bad, "w") as f:
                f.write("t,x\n1,2\n")
            with self.assertRaisesRegex(ValueError, "bad.csv: missing column"):
                nep.read_solution(bad)


if __name__ == "__main__":
    unittest.main()

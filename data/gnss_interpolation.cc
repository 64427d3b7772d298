#include "data/gnss_interpolation.h"

#include <algorithm>
#include <stdexcept>

namespace insid {

GnssSample interpolate_gnss(const std::vector<GnssSample>& gnss, double t_s) {
  if (gnss.empty()) throw std::invalid_argument("interpolate_gnss: no GNSS data");
  if (t_s <= gnss.front().t_s) return gnss.front();
  if (t_s >= gnss.back().t_s) return gnss.back();
  const auto it = std::upper_bound(gnss.begin(), gnss.end(), t_s,
                                   [](double t, const GnssSample& g) { return t < g.t_s; });
  const GnssSample& b = *it;
  const GnssSample& a = *(it - 1);
  const double w = (t_s - a.t_s) / (b.t_s - a.t_s);
  GnssSample out;
  out.t_s = t_s;
  out.lat_rad = a.lat_rad + w * (b.lat_rad - a.lat_rad);
  out.lon_rad = a.lon_rad + w * (b.lon_rad - a.lon_rad);
  out.h_m = a.h_m + w * (b.h_m - a.h_m);
  out.v_eb_n_mps = a.v_eb_n_mps + w * (b.v_eb_n_mps - a.v_eb_n_mps);
  return out;
}

}  // namespace insid

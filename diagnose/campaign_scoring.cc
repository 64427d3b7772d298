#include "diagnose/campaign_scoring.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Dense>

namespace insid::diagnose {

using json = nlohmann::json;

CaseLimits case_limits(const json& truth_row, double injected) {
  CaseLimits c;
  if (truth_row.is_null()) return c;
  c.has_row = true;
  // The row's sd is in SI, its min_detectable_sigma in catalogue sigmas: SI = sigma x sd/sd_sigma.
  c.min_detectable = truth_row["min_detectable_sigma"].get<double>() *
                     truth_row["sd"].get<double>() / truth_row["sd_sigma"].get<double>();
  c.detectable = truth_row["observable"].get<bool>() && std::abs(injected) >= c.min_detectable;
  if (truth_row.contains("collinear"))
    for (const json& p : truth_row["collinear"]) {
      const double rho = std::abs(p["correlation"].get<double>());
      if (rho > c.partner_correlation) {
        c.partner_correlation = rho;
        c.partner = p["effect"].get<std::string>();
      }
    }
  const double rho = std::min(c.partner_correlation, 1.0);
  c.inflation =
      rho < 1.0 ? 1.0 / std::sqrt(1.0 - rho * rho) : std::numeric_limits<double>::infinity();
  c.min_separable = c.min_detectable * c.inflation;
  c.separable = c.detectable && std::abs(injected) >= c.min_separable;
  return c;
}

double class_inflation(const json& first_candidates, const std::string& truth) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto row_of = [&](const std::string& name) -> const json* {
    for (const json& r : first_candidates)
      if (r["effect"] == name) return &r;
    return nullptr;
  };
  const json* t = row_of(truth);
  if (t == nullptr) return nan;
  std::vector<std::string> names = {truth};
  for (const json& p : (*t)["collinear"]) names.push_back(p["effect"].get<std::string>());
  const int k = static_cast<int>(names.size());
  if (k == 1) return 1.0;
  Eigen::MatrixXd R = Eigen::MatrixXd::Identity(k, k);
  for (int i = 0; i < k; ++i) {
    const json* ri = row_of(names[static_cast<std::size_t>(i)]);
    if (ri == nullptr) return nan;
    for (int j = 0; j < k; ++j) {
      if (i == j) continue;
      bool found = false;
      for (const json& p : (*ri)["collinear"])
        if (p["effect"] == names[static_cast<std::size_t>(j)]) {
          R(i, j) = p["correlation"].get<double>();
          found = true;
        }
      if (!found) return nan;
    }
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(0.5 * (R + R.transpose()));
  if (llt.info() != Eigen::Success) return nan;
  Eigen::VectorXd e0 = Eigen::VectorXd::Zero(k);
  e0[0] = 1.0;
  const double v = llt.solve(e0)[0];
  return v > 0 ? std::sqrt(v) : nan;
}

FirstName first_name(const json& found, const std::string& truth) {
  if (found.empty()) return FirstName::kNothing;
  const json& f = found[0];
  if (f["effect"] == truth) return FirstName::kTruth;
  for (const json& a : f["ambiguous_with"])
    if (a == truth) return FirstName::kTruthInFlaggedSet;
  return f["ambiguous_with"].empty() ? FirstName::kWrongUnflagged : FirstName::kWrongFlagged;
}

}  // namespace insid::diagnose

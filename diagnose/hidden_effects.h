// Hidden-effect test data for the diagnose tests and campaign (tests only: the workflow itself
// never uses this). A scenario preset with the paper's four biases (the preset's) plus hidden
// effects, nav-grade noise, written as data that look measured (no `injected`, no `noise` in
// meta.json).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include "data/dataset.h"

namespace insid::diagnose {

struct HiddenCase {
  std::string preset = "rich";
  double flight_s = 1200.0;
  std::uint64_t seed = 1;
  std::map<std::string, double> hidden;  ///< catalogue name -> SI value, on top of the preset
  std::string grade = "nav";
};

std::shared_ptr<const Dataset> make_hidden_dataset(const HiddenCase& c);

}  // namespace insid::diagnose

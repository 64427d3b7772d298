#include "diagnose/hidden_effects.h"

#include "scenarios/noise.h"
#include "scenarios/scenario.h"

namespace insid::diagnose {

std::shared_ptr<const Dataset> make_hidden_dataset(const HiddenCase& c) {
  scenarios::ScenarioOverrides overrides;
  overrides.flight_s = c.flight_s;
  overrides.seed = c.seed;
  overrides.grade = c.grade;
  overrides.set = c.hidden;
  return std::make_shared<const Dataset>(
      scenarios::simulate_preset(c.preset, overrides, /*record_truth_in_meta=*/false));
}

}  // namespace insid::diagnose

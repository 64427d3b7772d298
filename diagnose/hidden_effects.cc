#include "diagnose/hidden_effects.h"

#include "scenarios/noise.h"
#include "scenarios/scenario.h"

namespace insid::diagnose {

std::shared_ptr<const Dataset> make_hidden_dataset(const HiddenCase& c) {
  scenarios::ScenarioConfig cfg = scenarios::preset_scenario(c.preset);
  cfg.flight_s = c.flight_s;
  cfg.seed = c.seed;
  cfg.noise = scenarios::noise_grade(c.grade);
  for (const auto& [name, value] : c.hidden) add_effect(cfg.injected, name, value);
  return std::make_shared<const Dataset>(scenarios::simulate(cfg, /*record_truth_in_meta=*/false));
}

}  // namespace insid::diagnose

// libFuzzer target: scenario YAML text in, a validated scenario or a clean ConfigError out.
#include "fuzz_common.h"
#include "lander/sim/scenario.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = lander::fuzz::write_input(data, size, ".yaml");
  lander::fuzz::expect_clean([&] {
    const lander::sim::Scenario s = lander::sim::Scenario::load(path);
    // What loads must write back and load again to the same resolved text.
    const std::string text = lander::yaml_to_string(lander::params_to_yaml(s));
    lander::sim::Scenario again = lander::sim::Scenario::defaults();
    lander::read_params(YAML::Load(text), "resolved", again);
  });
  return 0;
}

// The PressureRegulator conformance suite (regulator_conformance.hpp) over
// the simulated backend.
#include "regulator_conformance.hpp"

#include <atomic>
#include <string>

#include "hw/pressure_regulator_sim.hpp"
#include "hw/sim_silence.hpp"
#include "hw/sim_world.hpp"

using namespace collide::hw;
using namespace collide::hw::testing;

namespace {

RegulatorBench simBench() {
  auto clock = std::make_shared<ManualClock>();
  auto profile = defaultRigProfile();
  auto world = SimWorld::create(*profile, clock);
  RegulatorSimSettings settings;
  settings.noise_kPa = 0.05;
  settings.time_constant_s = 0.01;
  // Silence is injected on demand: every bench its own device (a SimSilence
  // is shared by every simulated device of one name in the process).
  static std::atomic<int> benches{0};
  const std::string device = "sim-conformance-" + std::to_string(benches++);
  settings.fault = RegulatorSimSettings::Fault::Silent;
  settings.silent_after_setpoints = 1'000'000;
  RegulatorBench b{
      clock, *world, std::make_unique<PressureRegulatorSim>(*world, settings, device), {}};
  const std::string label = b.regulator->label();
  b.unplug = [label] { SimSilence::find(label)->goSilent(); };
  b.requests = [label] { return SimSilence::find(label)->unanswered(); };
  return b;
}

}  // namespace

INSTANTIATE_TEST_SUITE_P(Backends, RegulatorConformance,
                         ::testing::Values(RegulatorBackend{"sim", &simBench}),
                         [](const auto& info) { return info.param.name; });

// The PressureRegulator conformance suite (regulator_conformance.hpp) over
// the simulated backend.
#include "regulator_conformance.hpp"

#include "hw/pressure_regulator_sim.hpp"
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
  return {clock, *world, std::make_unique<PressureRegulatorSim>(*world, settings), {}};
}

}  // namespace

INSTANTIATE_TEST_SUITE_P(Backends, RegulatorConformance,
                         ::testing::Values(RegulatorBackend{"sim", &simBench}),
                         [](const auto& info) { return info.param.name; });

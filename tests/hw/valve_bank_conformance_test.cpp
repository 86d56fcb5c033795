// The ValveBank conformance suite (valve_bank_conformance.hpp) over the
// simulated bank on a manual clock.
#include "valve_bank_conformance.hpp"

#include "hw/sim_world.hpp"
#include "hw/valve_bank_sim.hpp"

using namespace collide::hw;
using namespace collide::hw::testing;

namespace {

ValveBench simBench() {
  auto clock = std::make_shared<ManualClock>();
  auto world = *SimWorld::create(*defaultRigProfile(), clock);
  ValveSimSettings s;
  s.count = 2;
  s.jitter_us = 20.0;
  ValveBench b{clock, world, std::make_unique<ValveBankSim>(world, clock, s)};
  b.no_unplug_reason =
      "the simulated valve bank has no device that can go away (its one fault, valves.fault = "
      "\"error\", is a driver that refuses to fire)";
  return b;
}

}  // namespace

INSTANTIATE_TEST_SUITE_P(Backends, ValveBankConformance,
                         ::testing::Values(ValveBackend{"sim", &simBench}),
                         [](const auto& info) { return info.param.name; });

#pragma once
// One simulated air line behind a regulator output: a first-order response to
// each new setpoint (time constant) until the line is within the regulator's
// hold band of its goal, where the regulator's own loop holds it at the goal;
// optionally a leak that lets a rise reach only part of the way. The one
// model of the regulator's dynamics, shared by the in-process simulated
// regulator (through SimWorld) and the simulated Modbus regulator that
// `collide sim-regulator` serves (ModbusRegulatorServer), so both answer a
// setpoint exactly alike.
//
// Threads: not synchronised; the owner locks (SimWorld) or uses one thread.
#include <cstdint>

namespace collide::hw {

/// How one simulated air line answers its regulator.
struct LineModel {
  double time_constant_s = 0.01;  ///< first-order response to a new setpoint, > 0
  /// Fraction of a pressure rise the line actually reaches: 1 for a sound
  /// line, < 1 for a leak (the pressure stalls short of the setpoint).
  double reach = 1.0;
  /// Within this of its goal (kPa) the regulator's loop holds the line at the
  /// goal, as a real regulator arrives at its setpoint. A pure first-order
  /// curve never arrives, so the pressure when the valves open would depend on
  /// how long the host took to get there. 0: the pure first-order curve.
  double hold_band_kPa = 0.0;
};

/// The fraction of a rise a leaking line reaches (regulator fault "never_settles").
inline constexpr double kLeakReach = 0.8;

class PressureLine {
 public:
  /// The pressure (gauge kPa) at `t_ns` (the caller's monotonic clock). After a
  /// new setpoint it moves from where it was towards the goal, and steps onto
  /// the goal (by at most the hold band) once within the band.
  double pressureKPa(std::int64_t t_ns) const;
  /// The last setpoint, kPa (0 before any).
  double targetKPa() const { return target_kPa_; }
  const LineModel& model() const { return model_; }

  /// A new setpoint from `now_ns` on.
  void command(double kPa, std::int64_t now_ns);
  /// A new response model from `now_ns` on (the pressure carries on from where it is).
  void setModel(const LineModel& model, std::int64_t now_ns);

 private:
  LineModel model_;
  double start_kPa_ = 0.0;   // pressure when the setpoint or model last changed
  double target_kPa_ = 0.0;  // where it is heading
  std::int64_t since_ns_ = 0;
};

}  // namespace collide::hw

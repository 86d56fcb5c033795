#include "hw/sim_world.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "hw/format.hpp"

namespace collide::hw {

namespace {

// A sphere whose valve never fired stays in its tube: Flight wants a launch
// time, so give it one no shot will ever reach.
constexpr double kNeverS = 1e6;

Vec3 randomUnit(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vec3 v;
  do v = Vec3(n(rng), n(rng), n(rng));
  while (v.norm() < 1e-9);
  return v.normalized();
}

Quat randomOrientation(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Quat q;
  do q = Quat(n(rng), n(rng), n(rng), n(rng));
  while (q.coeffs().norm() < 1e-9);
  return q.normalized();
}

}  // namespace

Result<std::shared_ptr<SimWorld>> SimWorld::create(const RigProfile& profile,
                                                   std::shared_ptr<Clock> clock) {
  Result<LaunchCalibration> curve = profile.calibration.curve();
  if (!curve) return fail(profile.source + ": calibration: " + curve.error().message);
  return std::shared_ptr<SimWorld>(new SimWorld(profile, std::move(clock), *curve));
}

SimWorld::SimWorld(const RigProfile& profile, std::shared_ptr<Clock> clock, LaunchCalibration curve)
    : profile_(profile),
      clock_(std::move(clock)),
      curve_(curve),
      rng_(profile.simulation.seed),
      regulator_rng_(profile.simulation.seed ^ 0x9e3779b97f4a7c15ULL),
      valves_rng_(profile.simulation.seed ^ 0xbf58476d1ce4e5b9ULL) {}

void SimWorld::setLineModel(int channel, LineModel model) {
  std::lock_guard lock(mutex_);
  lines_[channel].setModel(model, clock_->nowNs());
}

void SimWorld::commandPressureKPa(int channel, double kPa) {
  std::lock_guard lock(mutex_);
  lines_[channel].command(kPa, clock_->nowNs());
}

double SimWorld::linePressureKPa(int channel, std::int64_t t_ns) const {
  std::lock_guard lock(mutex_);
  const auto it = lines_.find(channel);
  return it == lines_.end() ? 0.0 : it->second.pressureKPa(t_ns);
}

void SimWorld::setPressureSource(std::function<Result<double>(int channel)> source) {
  std::lock_guard lock(mutex_);
  pressure_source_ = std::move(source);
}

double SimWorld::gaussian(Noise device, double sigma) {
  std::lock_guard lock(mutex_);
  return std::normal_distribution<double>(
      0.0, sigma)(device == Noise::Regulator ? regulator_rng_ : valves_rng_);
}

std::function<double(double)> SimWorld::restitutionLaw() const {
  const SimulationProfile& s = profile_.simulation;
  const double e0 = profile_.spheres.material.e;
  const double v_ref = s.restitution_ref_speed_m_s;
  const double k = s.restitution_exponent;
  switch (s.restitution) {
    case RestitutionLaw::Power:
      return [=](double vn) { return std::clamp(e0 * std::pow(vn / v_ref, -k), 0.0, 1.0); };
    case RestitutionLaw::Viscoelastic:
      return [=](double vn) {
        return std::clamp(1.0 - (1.0 - e0) * std::pow(vn / v_ref, 0.2), 0.0, 1.0);
      };
    case RestitutionLaw::Constant: break;
  }
  return {};
}

Status SimWorld::launch(const std::vector<ValveEvent>& events) {
  // A regulator outside the world is asked before taking the lock (it may be
  // a device on a wire); the valves open right after, with the pressure
  // settled, so "now" stands for the opening instant.
  std::function<Result<double>(int)> source;
  {
    std::lock_guard lock(mutex_);
    source = pressure_source_;
  }
  std::map<int, double> measured_kPa;  // per regulator channel
  if (source) {
    for (const LauncherProfile& l : profile_.launchers) {
      const bool fires = std::any_of(events.begin(), events.end(),
                                     [&](const ValveEvent& e) { return e.valve == l.valve; });
      if (!fires || measured_kPa.count(l.regulator_channel)) continue;
      Result<double> p = source(l.regulator_channel);
      if (!p) return fail("reading launcher " + l.name + "'s pressure: " + p.error().message);
      measured_kPa[l.regulator_channel] = *p;
    }
  }
  std::vector<std::function<void()>> callbacks;
  {
    std::lock_guard lock(mutex_);
    std::optional<std::int64_t> epoch;
    for (const ValveEvent& e : events) epoch = std::min(epoch.value_or(e.opened_ns), e.opened_ns);
    if (!epoch) return Ok{};

    auto shot = std::make_shared<SimLaunch>();
    shot->epoch_ns = *epoch;
    FlightSetup setup;
    setup.material = profile_.spheres.material;
    setup.wall = profile_.wall;  // a wall rig: launcher 2 never fires
    setup.restitution_of_vn = restitutionLaw();
    const SimulationProfile& sim = profile_.simulation;
    setup.air_density_kg_m3 = sim.air_density_kg_m3;
    std::normal_distribution<double> unit(0.0, 1.0);
    std::uniform_real_distribution<double> spin_rate(sim.spin_at_exit_rad_s[0],
                                                     sim.spin_at_exit_rad_s[1]);
    for (int i = 0; i < 2; ++i) {
      const LauncherProfile& l = profile_.launchers[i];
      Sphere& s = setup.spheres[i];
      s.mass_kg = profile_.spheres.mass_kg[i];
      s.diameter_m = profile_.spheres.diameter_m[i];
      s.position_m = l.exit_m;
      // Misalignment: sphere 2 out of the plane by D sin(tilt), D the
      // distance of the centres at contact.
      if (i == 1)
        s.position_m.z() += 0.5 *
                            (profile_.spheres.diameter_m[0] + profile_.spheres.diameter_m[1]) *
                            std::sin(sim.contact_tilt_rad);
      setup.launch_time_s[i] = kNeverS;
      setup.orientation_at_launch[i] = randomOrientation(rng_);
      shot->dots[i] = vision::DotPattern::random(rng_());

      const auto fired = std::find_if(events.begin(), events.end(),
                                      [&](const ValveEvent& e) { return e.valve == l.valve; });
      if (fired == events.end() || (setup.wall && i == 1)) continue;
      const auto line = lines_.find(l.regulator_channel);
      const double p_kPa = source                 ? measured_kPa.at(l.regulator_channel)
                           : line == lines_.end() ? 0.0
                                                  : line->second.pressureKPa(fired->opened_ns);
      const double v = curve_.speed_m_s(p_kPa) * (1.0 + sim.speed_scatter * unit(rng_));
      shot->pressure_kPa[i] = p_kPa;
      // Without pressure behind it the sphere stays in the tube.
      if (p_kPa < 1.0 || !(v > 0.05)) continue;
      Vec3 aim = (l.direction + sim.direction_scatter_rad *
                                    Vec3(unit(rng_), unit(rng_), unit(rng_)).cross(l.direction))
                     .normalized();
      // Drift out of the plane: a z velocity of about `drift` times the speed
      // (to first order; the scatter above adds its own).
      aim = (aim + sim.out_of_plane_drift * Vec3::UnitZ()).normalized();
      s.velocity_m_s = v * aim;
      s.spin_rad_s = spin_rate(rng_) * randomUnit(rng_);
      shot->launched[i] = true;
      shot->exit_speed_m_s[i] = v;
      shot->launch_ns[i] =
          fired->opened_ns + static_cast<std::int64_t>(profile_.calibration.exit_delay_s * 1e9);
      setup.launch_time_s[i] = shot->flightTimeS(shot->launch_ns[i]);
    }
    Result<Flight> flight = Flight::create(setup);
    if (!flight) return fail("simulated flight: " + flight.error().message);
    shot->flight = std::move(flight).value();
    launch_ = std::move(shot);
    launched_in_burst_ = true;
    callbacks = launch_callbacks_;
  }
  for (auto& c : callbacks) c();
  return Ok{};
}

std::shared_ptr<const SimLaunch> SimWorld::currentLaunch() const {
  std::lock_guard lock(mutex_);
  return launch_;
}

void SimWorld::beginBurst() {
  std::lock_guard lock(mutex_);
  launched_in_burst_ = false;
}

std::int64_t SimWorld::knownUntilNs() const {
  std::lock_guard lock(mutex_);
  return launched_in_burst_ ? std::numeric_limits<std::int64_t>::max() : clock_->nowNs();
}

void SimWorld::onLaunch(std::function<void()> callback) {
  std::lock_guard lock(mutex_);
  launch_callbacks_.push_back(std::move(callback));
}

std::optional<TruthRecord> SimWorld::truthFor(const vision::Burst& burst) const {
  const std::shared_ptr<const SimLaunch> shot = currentLaunch();
  if (!shot || burst.frames.empty() || !(burst.fps > 0)) return std::nullopt;
  // The burst's clock: seconds after frame 0's mid-exposure, found from any
  // frame (frame 0 itself may have been lost).
  const double period_ns = 1e9 / burst.fps;
  const double half_exposure_ns = burst.exposure_us * 500.0;
  const vision::Frame& any = burst.frames.front();
  const double zero_mid_ns =
      static_cast<double>(any.timestamp_ns) - any.id * period_ns + half_exposure_ns;

  TruthRecord t;
  t.material = shot->flight.materialUsed();
  t.t_collision_s =
      shot->flight.collides()
          ? (shot->epoch_ns + shot->flight.collisionTime_s() * 1e9 - zero_mid_ns) * 1e-9
          : std::numeric_limits<double>::quiet_NaN();
  for (const vision::Frame& f : burst.frames) {
    const double mid_ns = static_cast<double>(f.timestamp_ns) + half_exposure_ns;
    t.frame_id.push_back(f.id);
    t.t_s.push_back((mid_ns - zero_mid_ns) * 1e-9);
    t.states.push_back(shot->flight.at((mid_ns - shot->epoch_ns) * 1e-9));
  }
  for (int i = 0; i < 2; ++i) t.dot_centres[i] = shot->dots[i].centres;
  t.dot_angular_radius_rad = shot->dots[0].angular_radius_rad;
  return t;
}

}  // namespace collide::hw

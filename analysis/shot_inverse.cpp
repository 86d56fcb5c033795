#include "analysis/shot_inverse.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace collide {

ShotInverse invertShot(const ContactState& st, const ShotInverseSettings& in) {
  ShotInverse o;
  o.v_after = st.v_after;
  std::array<Sphere, 2> before, after;
  for (int s = 0; s < 2; ++s) {
    const Eigen::Vector2d& p = st.position_m[s];
    before[s].mass_kg = after[s].mass_kg = in.mass_kg[s];
    before[s].diameter_m = after[s].diameter_m = in.diameter_m[s];
    before[s].position_m = after[s].position_m = Vec3(p.x(), p.y(), 0);
    before[s].velocity_m_s = st.v_before[s];
    before[s].spin_rad_s = st.w_before[s];
    after[s].velocity_m_s = st.v_after[s];
    after[s].spin_rad_s = st.w_after[s];
  }
  {
    const Vec3 dr = before[0].position_m - before[1].position_m;
    const Eigen::Vector2d n2 = dr.head<2>().normalized();
    const double m12 = in.mass_kg[0] * in.mass_kg[1] / (in.mass_kg[0] + in.mass_kg[1]);
    const Vec3 dp = m12 * ((st.v_after[0] - st.v_before[0]) - (st.v_after[1] - st.v_before[1]));
    Eigen::Matrix2d ata = Eigen::Matrix2d::Zero();
    Eigen::Vector2d atb = Eigen::Vector2d::Zero();
    for (int s = 0; s < 2; ++s) {
      const double c = in.mass_kg[s] * in.diameter_m[s] / 5.0;
      const Vec3 dw = st.w_after[s] - st.w_before[s];
      const Eigen::Matrix3d& cov = in.spin_change_cov[s];
      for (int row = 0; row < 2; ++row) {
        const Eigen::Vector2d a =
            row == 0 ? Eigen::Vector2d(dp.y(), -n2.y()) : Eigen::Vector2d(-dp.x(), n2.x());
        const double var = c * c * std::max(cov(row, row), 1e-12);
        ata += a * a.transpose() / var;
        atb += a * (c * dw[row]) / var;
      }
    }
    const double sz = std::max(in.nz_sigma, 1e-6);
    ata(0, 0) += 1.0 / (sz * sz);
    atb[0] += in.nz_prior / (sz * sz);
    const Eigen::Vector2d x = ata.ldlt().solve(atb);
    if (x.allFinite()) {
      const double nz = std::clamp(x[0], -0.2, 0.2);
      // Sphere 1 towards the camera from sphere 2 by n_z of the contact distance.
      const double dz = nz * dr.head<2>().norm() / std::sqrt(1 - nz * nz);
      before[0].position_m.z() = after[0].position_m.z() = 0.5 * dz;
      before[1].position_m.z() = after[1].position_m.z() = -0.5 * dz;
      o.v_after[0].z() = after[0].velocity_m_s.z() = st.v_before[0].z() + x[1] / in.mass_kg[0];
      o.v_after[1].z() = after[1].velocity_m_s.z() = st.v_before[1].z() - x[1] / in.mass_kg[1];
      o.n_z = nz;
    }
  }
  auto m = measureCollision(before, after);
  if (!m) return o;
  o.m = *m;
  o.vs_after = m->after.v_s_vec_m_s.dot(m->before.tangent);
  for (int s = 0; s < 2; ++s) {
    const double mass = in.mass_kg[s], inertia = before[s].inertia_kg_m2();
    const double kb = 0.5 * mass * before[s].velocity_m_s.squaredNorm() +
                      0.5 * inertia * before[s].spin_rad_s.squaredNorm();
    const double ka = 0.5 * mass * after[s].velocity_m_s.squaredNorm() +
                      0.5 * inertia * after[s].spin_rad_s.squaredNorm();
    o.kinetic_energy_before_J += kb;
    o.kinetic_energy_change_J += ka - kb;
  }
  o.ok = true;
  return o;
}

std::vector<std::string> unphysicalFindings(const ValueSigma& e, const ValueSigma& beta,
                                            const ValueSigma& dke, double k) {
  const auto sig = [](const ValueSigma& v) { return std::isfinite(v.sigma) ? v.sigma : 0.0; };
  const auto say = [](const char* spec, double a, double b) {
    char buf[200];
    std::snprintf(buf, sizeof buf, spec, a, b);
    return std::string(buf);
  };
  std::vector<std::string> out;
  if (std::isfinite(e.value)) {
    if (e.value > 1 + k * sig(e))
      out.push_back(say("e = %.4f +- %.4f exceeds 1: the spheres part faster than they met",
                        e.value, sig(e)));
    if (e.value < -k * sig(e))
      out.push_back(say("e = %.4f +- %.4f is negative: the spheres still approach after the impact",
                        e.value, sig(e)));
  }
  if (std::isfinite(beta.value) && std::abs(beta.value) > 1 + k * sig(beta))
    out.push_back(say("beta = %.4f +- %.4f lies outside [-1, 1]", beta.value, sig(beta)));
  if (std::isfinite(dke.value) && dke.value > k * sig(dke))
    out.push_back(say("the spheres gained %.3g +- %.2g J of kinetic energy in the impact",
                      dke.value, sig(dke)));
  return out;
}

std::optional<std::string> spinImpulseDisagreement(double beta, double beta_from_impulse,
                                                   double sigma, double k) {
  const double diff = beta - beta_from_impulse;
  if (!std::isfinite(diff) || !(sigma > 0) || !(std::abs(diff) > k * sigma)) return std::nullopt;
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "beta from the spins (%+.3f) and from the impulse the velocities show (%+.3f) "
                "differ by %.1f sigma: angular momentum is not conserved, so a measured spin or "
                "velocity is probably wrong (look at the dots in the frames' overlay)",
                beta, beta_from_impulse, std::abs(diff) / sigma);
  return std::string(buf);
}

}  // namespace collide

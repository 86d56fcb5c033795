#pragma once
// A slow wander of tracked centres for tests: a Gaussian process of RMS `rms`
// whose samples at t_i, t_j correlate as exp(-(t_i - t_j)^2 / (2 time^2)),
// drawn through the Cholesky factor of its covariance (a jitter of 1e-10 of
// the variance on the diagonal keeps the factor defined). Independent of
// analysis/residual_structure's wanderSigma, which it checks.
#include <Eigen/Dense>
#include <cmath>
#include <random>

namespace collide::testing {

class CorrelatedWander {
 public:
  CorrelatedWander(const Eigen::VectorXd& t, double rms, double time_s) {
    const Eigen::Index n = t.size();
    Eigen::MatrixXd k(n, n);
    for (Eigen::Index i = 0; i < n; ++i)
      for (Eigen::Index j = 0; j < n; ++j) {
        const double d = (t[i] - t[j]) / time_s;
        k(i, j) = rms * rms * (std::exp(-0.5 * d * d) + (i == j ? 1e-10 : 0.0));
      }
    factor_ = Eigen::LLT<Eigen::MatrixXd>(k).matrixL();
  }
  template <class Rng>
  Eigen::VectorXd draw(Rng& rng) const {
    std::normal_distribution<double> nd;
    Eigen::VectorXd z(factor_.rows());
    for (Eigen::Index i = 0; i < z.size(); ++i) z[i] = nd(rng);
    return factor_ * z;
  }

 private:
  Eigen::MatrixXd factor_;
};

}  // namespace collide::testing

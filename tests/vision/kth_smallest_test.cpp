// kthSmallest against std::nth_element (an implementation written
// elsewhere): the same value at every rank, for sizes around the insertion
// sort's cut-off and well beyond it, with distinct values, many ties, all
// values equal, sorted and reversed input, and +infinities among them.
#include "vision/kth_smallest.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

using collide::vision::kthSmallest;

namespace {

double reference(std::vector<double> v, std::size_t k) {
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

void expectEveryRank(const std::vector<double>& values) {
  std::vector<double> scratch;
  for (std::size_t k = 0; k < values.size(); ++k) {
    std::vector<double> v = values;
    const double got = kthSmallest(v.data(), v.size(), k, scratch);
    ASSERT_EQ(got, reference(values, k)) << "rank " << k << " of " << values.size();
  }
}

}  // namespace

TEST(KthSmallest, AgreesWithNthElementOnDistinctValues) {
  std::mt19937 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (std::size_t n : {1, 2, 3, 23, 24, 25, 26, 50, 171, 400}) {
    std::vector<double> v(n);
    for (double& x : v) x = std::abs(normal(rng));
    expectEveryRank(v);
  }
}

TEST(KthSmallest, AgreesWithNthElementOnTies) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> few(0, 4);
  for (std::size_t n : {25, 60, 300}) {
    std::vector<double> v(n);
    for (double& x : v) x = 0.25 * few(rng);
    expectEveryRank(v);
    expectEveryRank(std::vector<double>(n, 1.5));  // all equal
  }
}

TEST(KthSmallest, AgreesWithNthElementOnOrderedInput) {
  std::vector<double> up(200);
  for (std::size_t i = 0; i < up.size(); ++i) up[i] = static_cast<double>(i) * 0.1;
  expectEveryRank(up);
  std::reverse(up.begin(), up.end());
  expectEveryRank(up);
}

// The circle fit's median sets the points out of use to +infinity
// (vision/sphere_detector.cpp, residuals): at the ranks below them, the same
// value as over the finite values alone.
TEST(KthSmallest, InfinitiesRankAboveEveryFiniteValue) {
  std::mt19937 rng(13);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::bernoulli_distribution out(0.2);
  for (std::size_t n : {10, 30, 171, 300}) {
    std::vector<double> v(n), finite;
    for (double& x : v) {
      x = out(rng) ? std::numeric_limits<double>::infinity() : std::abs(normal(rng));
      if (std::isfinite(x)) finite.push_back(x);
    }
    expectEveryRank(v);
    std::vector<double> scratch;
    for (std::size_t k = 0; k < finite.size(); ++k) {
      std::vector<double> w = v;
      ASSERT_EQ(kthSmallest(w.data(), w.size(), k, scratch), reference(finite, k))
          << "rank " << k << " of " << finite.size() << " finite among " << n;
    }
  }
}

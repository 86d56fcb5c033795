#include "analysis/error_model.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace collide;

// The thesis' own numbers: s ~ 1.5 sub-pixels of 1/4 px, d = 2.54 cm imaged on
// ~37 px, 1000 frames/s, ~10 frames per side -> velocity std ~ 4 cm/s (docs/SPEC.md).
TEST(ErrorModel, ThesisImagingGivesCentimetresPerSecond) {
  ImagingGeometry g{.position_sigma_px = 1.5 * 0.25,
                    .pixels_per_diameter = 37.2,
                    .diameter_m = 0.0254,
                    .frame_interval_s = 1e-3,
                    .frames_per_side = 10};
  const double sigma = velocitySigma_m_s(g);
  EXPECT_GT(sigma, 0.01);
  EXPECT_LT(sigma, 0.10);
}

TEST(ErrorModel, ScalesAsEquation51) {
  ImagingGeometry g{.position_sigma_px = 0.5,
                    .pixels_per_diameter = 100,
                    .diameter_m = 0.02,
                    .frame_interval_s = 1e-3,
                    .frames_per_side = 4};
  const double base = velocitySigma_m_s(g);
  EXPECT_NEAR(base, 0.5 * 0.02 / (100 * 1e-3 * 2.0), 1e-15);
  g.frames_per_side = 16;  // 4x frames -> half the error
  EXPECT_NEAR(velocitySigma_m_s(g), base / 2, 1e-15);
  EXPECT_NEAR(relativeVelocityError(g, 2.0), base / 2 / 2.0, 1e-15);
  EXPECT_TRUE(std::isinf(relativeVelocityError(g, 0.0)));
  g.frames_per_side = 0;
  EXPECT_TRUE(std::isinf(velocitySigma_m_s(g)));
}

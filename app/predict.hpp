#pragma once
// `collide predict`: what Walton's model predicts for one planned collision,
// JSON in, JSON out. The format is documented in `collide predict --help`
// (app/cli/predict.cpp) and shown in docs/examples/predict-nylon.json.
#include <nlohmann/json.hpp>
#include <string_view>

#include "analysis/result.hpp"

namespace collide::app {

/// Input: {"material": {"e", "mu", "beta0"},
///         "spheres": [sphere, sphere]  or  [sphere, {"wall": {"point_m", "normal"}}]}
/// with sphere = {"diameter_m", "mass_kg", "position_m", "velocity_m_s", "spin_rad_s"}
/// (SI units, vectors as [x, y, z], every field required, no others allowed).
/// Output: {"spheres": [{"velocity_m_s", "spin_rad_s"}, ...] (one entry per
/// sphere: one for a wall), "regime": "sliding"|"rolling", "e", "beta", "f",
/// "gamma_deg", "vn_m_s", "vs_m_s", "normal", "impulse_N_s"} (impulse on
/// spheres[0], N s; normal from the second body towards spheres[0]).
/// Errors: a one-line message starting with the JSON path of the offending
/// field, e.g. "spheres[1].diameter_m: must be > 0 (got -0.0254)": missing
/// field, wrong type, unknown field, non-finite number, invalid material,
/// bodies not touching within 1 %, not approaching.
Result<nlohmann::json> predict(const nlohmann::json& in);

/// Parses one JSON value from text. Errors: "<source>: invalid JSON: <where, why>".
Result<nlohmann::json> parseJson(std::string_view text, std::string_view source);

}  // namespace collide::app

// `collide predict`: one planned collision through Walton's operator.
#include "app/predict.hpp"

#include <fstream>
#include <iostream>
#include <iterator>
#include <memory>
#include <sstream>

#include "app/cli/command.hpp"

namespace {

constexpr const char* kFormat = R"(
Input (one JSON object; SI units; vectors [x, y, z]; x right, y up, z towards the camera):
  {"material": {"e": 0.97, "mu": 0.176, "beta0": 0.44},
   "spheres": [{"diameter_m": 0.0254, "mass_kg": 0.00979, "position_m": [x, y, z],
                "velocity_m_s": [x, y, z], "spin_rad_s": [x, y, z]},
               <second sphere, same fields>]}
  Every field is required. The spheres must touch (centre distance within 1 % of
  (d1 + d2)/2) and approach each other.
  Sphere against a fixed wall: the wall takes the place of the second sphere,
    "spheres": [<sphere>, {"wall": {"point_m": [x, y, z], "normal": [x, y, z]}}]
  (any point on the plane; the normal need not be unit length nor face the sphere;
  the sphere's centre must be one radius from the plane within 1 %).

Output (one JSON object):
  {"spheres": [{"velocity_m_s": [...], "spin_rad_s": [...]}, ...],  one entry per sphere
              (a single entry for a wall),
   "regime": "sliding" | "rolling", "e", "beta", "f", "gamma_deg" (incidence angle,
   180 head-on), "vn_m_s" (< 0), "vs_m_s", "normal" (from the second body towards
   the first), "impulse_N_s" (on the first sphere)}

Exit status: 0 done; 2 bad input, with one line on stderr naming the field.
Example: collide predict docs/examples/predict-nylon.json)";

void setupPredict(CLI::App& sub, std::function<int()>& run) {
  auto path = std::make_shared<std::string>("-");
  sub.add_option("input", *path, "JSON input file; '-' or none reads standard input");
  sub.footer(kFormat);
  run = [path] {
    using collide::cli::kExitBadInput;
    const bool from_stdin = *path == "-";
    const std::string source = from_stdin ? "standard input" : *path;
    std::string text;
    if (from_stdin) {
      text.assign(std::istreambuf_iterator<char>(std::cin), {});
    } else {
      std::ifstream file(*path, std::ios::binary);
      if (!file) {
        std::cerr << "collide predict: " << source << ": cannot open; check the path\n";
        return kExitBadInput;
      }
      std::ostringstream buffer;
      buffer << file.rdbuf();
      text = buffer.str();
    }
    auto in = collide::app::parseJson(text, source);
    if (!in) {
      std::cerr << "collide predict: " << in.error().message << "\n";
      return kExitBadInput;
    }
    auto out = collide::app::predict(*in);
    if (!out) {
      std::cerr << "collide predict: " << out.error().message << "\n";
      return kExitBadInput;
    }
    std::cout << out->dump(2) << "\n";
    return collide::cli::kExitOk;
  };
}

}  // namespace

COLLIDE_COMMAND(predict, "What Walton's model predicts for a planned shot (JSON in, JSON out)",
                setupPredict);

#include "app/predict.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <sstream>

using collide::app::parseJson;
using collide::app::predict;
using nlohmann::json;
using ::testing::HasSubstr;
using ::testing::StartsWith;

namespace {

constexpr double kD = 0.0254, kM = 0.00979;

json sphere(std::array<double, 3> position_m, std::array<double, 3> velocity_m_s,
            std::array<double, 3> spin_rad_s = {0, 0, 0}) {
  return {{"diameter_m", kD},
          {"mass_kg", kM},
          {"position_m", position_m},
          {"velocity_m_s", velocity_m_s},
          {"spin_rad_s", spin_rad_s}};
}

// Identical spheres, n = +x, sphere 2 at rest, sphere 1 arriving with
// v_n = -1 and v_s = 2 m/s: grazing enough to slide with Nylon's numbers.
json obliqueInput(double e, double mu, double beta0) {
  return {{"material", {{"e", e}, {"mu", mu}, {"beta0", beta0}}},
          {"spheres", {sphere({kD, 0, 0}, {-1, 2, 0}), sphere({0, 0, 0}, {0, 0, 0})}}};
}

std::array<double, 3> vec(const json& j) {
  return {j[0], j[1], j[2]};
}

}  // namespace

// Analytic sliding collision (SPEC): dP_n = m_12 (1 + e)|v_n| along n, dP_t =
// -mu |dP_n| t with t = +y, m_12 = m/2; each sphere's spin changes by
// -(sigma/2)/I n x dP = 5 mu (1 + e) |v_n| / (2 sigma) about z.
TEST(Predict, ObliqueSlidingMatchesAnalyticAnswer) {
  const double e = 0.97, mu = 0.176, beta0 = 0.44;
  auto out = predict(obliqueInput(e, mu, beta0));
  ASSERT_TRUE(out.ok()) << out.error().message;
  const json& o = *out;
  EXPECT_EQ(o["regime"], "sliding");
  const double v1x = -1 + (1 + e) / 2, v1y = 2 - mu * (1 + e) / 2;
  const double dw = 5 * mu * (1 + e) / (2 * kD);
  const auto a0 = o["spheres"][0], a1 = o["spheres"][1];
  EXPECT_NEAR(vec(a0["velocity_m_s"])[0], v1x, 1e-14);
  EXPECT_NEAR(vec(a0["velocity_m_s"])[1], v1y, 1e-14);
  EXPECT_NEAR(vec(a1["velocity_m_s"])[0], -(1 + e) / 2, 1e-14);
  EXPECT_NEAR(vec(a1["velocity_m_s"])[1], mu * (1 + e) / 2, 1e-14);
  EXPECT_NEAR(vec(a0["spin_rad_s"])[2], dw, 1e-11);
  EXPECT_NEAR(vec(a1["spin_rad_s"])[2], dw, 1e-11);
  EXPECT_EQ(vec(a0["velocity_m_s"])[2], 0.0);
  EXPECT_DOUBLE_EQ(o["e"].get<double>(), e);
  EXPECT_NEAR(o["f"].get<double>(), mu, 1e-14);
  EXPECT_NEAR(o["beta"].get<double>(), -1 + 3.5 * mu * (1 + e) / 2, 1e-14);
  EXPECT_NEAR(o["gamma_deg"].get<double>(), std::atan2(2.0, -1.0) * 180 / std::numbers::pi, 1e-12);
  EXPECT_NEAR(o["vn_m_s"].get<double>(), -1.0, 1e-15);
  EXPECT_NEAR(o["vs_m_s"].get<double>(), 2.0, 1e-15);
}

TEST(Predict, WallBounceIsMinusEVAndReportsOneSphere) {
  json in = {{"material", {{"e", 0.8}, {"mu", 0.2}, {"beta0", 0.4}}},
             {"spheres",
              {sphere({0, kD / 2, 0}, {0, -3, 0}),
               {{"wall", {{"point_m", {1, 0, 1}}, {"normal", {0, 2, 0}}}}}}}};
  auto out = predict(in);
  ASSERT_TRUE(out.ok()) << out.error().message;
  ASSERT_EQ((*out)["spheres"].size(), 1u);
  const auto v = vec((*out)["spheres"][0]["velocity_m_s"]);
  EXPECT_NEAR(v[1], 0.8 * 3, 1e-14);
  EXPECT_EQ(v[0], 0.0);
  EXPECT_EQ((*out)["regime"], "rolling");
}

TEST(Predict, RejectsBadValuesNamingTheField) {
  auto expectError = [](json in, const std::string& prefix) {
    auto out = predict(in);
    ASSERT_FALSE(out.ok()) << prefix;
    EXPECT_THAT(out.error().message, StartsWith(prefix));
  };
  const json good = obliqueInput(0.97, 0.176, 0.44);
  ASSERT_TRUE(predict(good).ok());
  json in = good;
  in["spheres"][1]["diameter_m"] = -0.0254;
  expectError(in, "spheres[1].diameter_m: must be > 0");
  in = good;
  in["spheres"][0]["velocity_m_s"][1] = std::numeric_limits<double>::quiet_NaN();
  expectError(in, "spheres[0].velocity_m_s");
  in = good;
  in["spheres"][0]["mass_kg"] = std::numeric_limits<double>::infinity();
  expectError(in, "spheres[0].mass_kg");
  in = good;
  in["spheres"][1].erase("spin_rad_s");
  expectError(in, "spheres[1].spin_rad_s: missing");
  in = good;
  in["spheres"][1]["spin"] = {0, 0, 0};
  expectError(in, "spheres[1].spin: unknown field");
  in = good;
  in["material"]["mu"] = "high";
  expectError(in, "material.mu: must be a number");
  in = good;
  in["material"]["e"] = 1.2;
  expectError(in, "material.e");
  in = good;
  in["spheres"][0]["position_m"] = {0.0254, 0};
  expectError(in, "spheres[0].position_m: must be an array of 3");
  in = good;
  in["spheres"] = {good["spheres"][0]};
  expectError(in, "spheres: must be an array of two");
  in = good;
  in["spheres"][0]["position_m"] = {0.03, 0, 0};
  expectError(in, "spheres[].position_m");
  in = good;
  in["spheres"][0]["velocity_m_s"] = {1, 2, 0};
  expectError(in, "spheres[].velocity_m_s");
  expectError(json::array({1, 2}), "input: must be a JSON object");
}

TEST(Predict, ParseJsonReportsSourceAndPosition) {
  auto bad = parseJson("{\"material\": NaN}", "shot.json");
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.error().message, StartsWith("shot.json: invalid JSON: parse error at line 1"));
  EXPECT_TRUE(parseJson("{\"a\": [1, 2]}", "x").ok());
}

// The built program, as a user runs it.
namespace {

struct ProgramRun {
  int status = -1;
  std::string out, err;
};

std::string slurp(const std::filesystem::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

class PredictProgram : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::path(::testing::TempDir()) /
           ("predict_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::filesystem::path write(const std::string& name, const std::string& text) {
    const auto p = dir_ / name;
    std::ofstream(p) << text;
    return p;
  }

  // args are appended to `collide predict`; stdin_file (if any) is fed on stdin.
  ProgramRun run(const std::string& args, const std::filesystem::path& stdin_file = {}) {
    const auto out = dir_ / "stdout", err = dir_ / "stderr";
    std::string cmd = std::string(COLLIDE_BINARY_DIR "/app/collide predict ") + args;
    if (!stdin_file.empty()) cmd += " < '" + stdin_file.string() + "'";
    cmd += " > '" + out.string() + "' 2> '" + err.string() + "'";
    const int raw = std::system(cmd.c_str());
    ProgramRun r;
    r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
    r.out = slurp(out);
    r.err = slurp(err);
    return r;
  }

  std::filesystem::path dir_;
};

const std::string kExample = COLLIDE_SOURCE_DIR "/docs/examples/predict-nylon.json";

}  // namespace

TEST_F(PredictProgram, ExampleFileGivesValidJson) {
  for (const ProgramRun& r :
       {run(std::string("'") + kExample + "'"), run("", kExample), run("-", kExample)}) {
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.err, "");
    const json out = json::parse(r.out);  // throws (test fails) if not JSON
    ASSERT_EQ(out["spheres"].size(), 2u);
    EXPECT_TRUE(out["regime"] == "sliding" || out["regime"] == "rolling");
    for (const char* key : {"e", "beta", "f", "gamma_deg", "vn_m_s", "vs_m_s"})
      EXPECT_TRUE(out[key].is_number()) << key;
    // Identical spheres: momentum conservation means opposite velocity changes.
    const json in = json::parse(slurp(kExample));
    for (int k = 0; k < 3; ++k) {
      const double dv1 = out["spheres"][0]["velocity_m_s"][k].get<double>() -
                         in["spheres"][0]["velocity_m_s"][k].get<double>();
      const double dv2 = out["spheres"][1]["velocity_m_s"][k].get<double>() -
                         in["spheres"][1]["velocity_m_s"][k].get<double>();
      EXPECT_NEAR(dv1, -dv2, 1e-12);
    }
  }
}

TEST_F(PredictProgram, BadInputExitsTwoNamingTheField) {
  const json good = json::parse(slurp(kExample));
  struct Case {
    std::string name, text, expected;
  };
  auto modified = [&](auto change) {
    json j = good;
    change(j);
    return j.dump();
  };
  const std::vector<Case> cases = {
      {"invalid", "{\"material\": ", "invalid JSON"},
      {"nan", "{\"material\": {\"e\": NaN}}", "invalid JSON"},
      {"overflow", R"({"material": {"e": 1e999, "mu": 0.1, "beta0": 0.4}, "spheres": []})",
       "invalid JSON"},
      {"missing", modified([](json& j) { j["spheres"][0].erase("mass_kg"); }),
       "spheres[0].mass_kg"},
      {"type", modified([](json& j) { j["spheres"][1]["velocity_m_s"] = "fast"; }),
       "spheres[1].velocity_m_s"},
      {"negative", modified([](json& j) { j["spheres"][1]["diameter_m"] = -0.0254; }),
       "spheres[1].diameter_m: must be > 0"},
      {"zero_mass", modified([](json& j) { j["spheres"][0]["mass_kg"] = 0; }),
       "spheres[0].mass_kg: must be > 0"},
      {"apart", modified([](json& j) {
         j["spheres"][0]["position_m"] = {-0.03, 0.0, 0.0};
       }),
       "position_m"},
      {"receding", modified([](json& j) {
         j["spheres"][0]["velocity_m_s"] = {-1.5, 0.0, 0.0};
       }),
       "velocity_m_s"},
      {"material", modified([](json& j) { j["material"]["beta0"] = 2; }), "material.beta0"},
      {"wall", modified([](json& j) {
         j["spheres"][1] = {{"wall", {{"point_m", {0, 0, 0}}, {"normal", {0, 0, 0}}}}};
       }),
       "spheres[1].wall"},
  };
  for (const Case& c : cases) {
    const ProgramRun r = run(std::string("'") + write(c.name + ".json", c.text).string() + "'");
    EXPECT_EQ(r.status, 2) << c.name;
    EXPECT_THAT(r.err, StartsWith("collide predict: ")) << c.name;
    EXPECT_THAT(r.err, HasSubstr(c.expected)) << c.name;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.name << ": " << r.err;
    EXPECT_EQ(r.out, "") << c.name;
  }
  // The same through standard input, and a file that is not there.
  const ProgramRun piped = run("", write("neg.json", cases[5].text));
  EXPECT_EQ(piped.status, 2);
  EXPECT_THAT(piped.err, HasSubstr("spheres[1].diameter_m"));
  const ProgramRun missing = run(std::string("'") + (dir_ / "no-such.json").string() + "'");
  EXPECT_EQ(missing.status, 2);
  EXPECT_THAT(missing.err, HasSubstr("no-such.json"));
}

TEST_F(PredictProgram, HelpDocumentsTheWallForm) {
  const ProgramRun r = run("--help");
  EXPECT_EQ(r.status, 0);
  EXPECT_THAT(r.out, HasSubstr("\"wall\""));
  EXPECT_THAT(r.out, HasSubstr("single entry for a wall"));
}

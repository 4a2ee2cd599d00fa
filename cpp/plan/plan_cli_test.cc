#include "plan/plan_cli.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "common/atomic_file.h"
#include "tsp/tsplib.h"

namespace mound::plan {
namespace {

struct CliRun {
  int code;
  std::string out, err;
};

CliRun Call(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  const int code = RunMoundPlan(args, out, err);
  return {code, out.str(), err.str()};
}

std::string TempPath(const std::string& name) { return ::testing::TempDir() + "/" + name; }

bool Exists(const std::string& p) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0;
}

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string p = TempPath(name);
  std::ofstream(p) << text;
  return p;
}

nlohmann::json GoodSites() {
  return nlohmann::json::parse(R"({
    "schema": "mound.sites", "version": 1,
    "origin": {"lat": 38.5705, "lon": 27.9862, "alt_m": 95.0},
    "home": {"id": "home", "x_m": 0, "y_m": 0},
    "budget_m": 30,
    "sites": [
      {"id": "a", "x_m": 3, "y_m": 4, "reward": 1.0, "scan_cost_m": 1},
      {"id": "b", "x_m": 6, "y_m": 8, "reward": 0.5},
      {"id": "c", "x_m": -3, "y_m": 4, "reward": 0.9, "scan_cost_m": 0.5},
      {"id": "d", "x_m": 20, "y_m": 20, "reward": 1.0}
    ]})");
}

TEST(PlanCliTest, WritesAValidPlanAtomically) {
  const std::string in = WriteTemp("good.json", GoodSites().dump());
  const std::string out = TempPath("plan.json");
  std::remove(out.c_str());
  const CliRun r = Call({in, "25", "--out", out, "--seed", "2"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto plan = nlohmann::json::parse(ReadFile(out));
  EXPECT_EQ(plan["schema"], "mound.plan");
  EXPECT_EQ(plan["version"], 1);
  EXPECT_EQ(plan["status"], "ok");
  EXPECT_EQ(plan["budget_m"], 25.0);  // the command line overrides the file
  EXPECT_EQ(plan["budget_source"], "command line");
  EXPECT_EQ(plan["tour"].front(), "home");
  EXPECT_EQ(plan["tour"].back(), "home");
  EXPECT_LE(plan["cost_m"].get<double>(), 25.0);
  EXPECT_NEAR(plan["budget_left_m"].get<double>(), 25.0 - plan["cost_m"].get<double>(), 1e-9);
  // By hand: home-c-a-home costs 5.25 + 6.75 + 5.5 = 17.5 (reward 1.9); adding b needs
  // 27.5 and b alone with a gives 1.5; d is out of reach.
  EXPECT_NEAR(plan["reward"].get<double>(), 1.9, 1e-9);
  EXPECT_EQ(plan["origin"]["lat"], 38.5705);
}

TEST(PlanCliTest, EndNodeGivesAPath) {
  auto j = GoodSites();
  j["end"] = {{"id", "landing"}, {"x_m", 10}, {"y_m", 0}};
  const std::string in = WriteTemp("path.json", j.dump());
  const CliRun r = Call({in, "--algo", "exact"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto plan = nlohmann::json::parse(r.out);
  EXPECT_EQ(plan["tour"].front(), "home");
  EXPECT_EQ(plan["tour"].back(), "landing");
  EXPECT_FALSE(plan["closed"].get<bool>());
}

struct BadCase {
  const char* name;
  std::function<std::string()> text;  // file contents
  std::vector<std::string> extra;     // extra arguments
  const char* must_name;              // substring of the message
};

TEST(PlanCliTest, BadInputExitsTwoWithOneLineNamingTheFieldAndWritesNothing) {
  auto with = [](auto edit) {
    return [edit]() {
      auto j = GoodSites();
      edit(j);
      return j.dump();
    };
  };
  const std::vector<BadCase> cases = {
      {"missing home", with([](auto& j) { j.erase("home"); }), {}, "home"},
      {"missing x", with([](auto& j) { j["sites"][1].erase("x_m"); }), {}, "sites[1].x_m"},
      {"missing reward",
       with([](auto& j) { j["sites"][2].erase("reward"); }),
       {},
       "sites[2].reward"},
      {"NaN literal",
       [] {
         return std::string(R"({"schema": "mound.sites", "version": 1,
         "home": {"id": "h", "x_m": 0, "y_m": 0}, "budget_m": 9,
         "sites": [{"id": "a", "x_m": 1, "y_m": 1, "reward": NaN}]})");
       },
       {},
       "reward"},
      {"negative reward",
       with([](auto& j) { j["sites"][0]["reward"] = -1; }),
       {},
       "sites[0].reward"},
      {"negative scan",
       with([](auto& j) { j["sites"][3]["scan_cost_m"] = -2; }),
       {},
       "sites[3].scan_cost_m"},
      {"negative budget", with([](auto& j) { j["budget_m"] = -5; }), {}, "budget_m"},
      {"string coord", with([](auto& j) { j["sites"][0]["y_m"] = "4"; }), {}, "sites[0].y_m"},
      {"duplicate id", with([](auto& j) { j["sites"][2]["id"] = "a"; }), {}, "sites[2].id"},
      {"site named like home",
       with([](auto& j) { j["sites"][1]["id"] = "home"; }),
       {},
       "sites[1].id"},
      {"unknown version", with([](auto& j) { j["version"] = 7; }), {}, "version"},
      {"wrong schema", with([](auto& j) { j["schema"] = "mound.plan"; }), {}, "schema"},
      {"empty sites", with([](auto& j) { j["sites"] = nlohmann::json::array(); }), {}, "sites"},
      {"sites not array", with([](auto& j) { j["sites"] = 3; }), {}, "sites"},
      {"budget too small", with([](auto& j) { j["budget_m"] = 2; }), {}, "budget_m"},
      {"path budget too small",
       with([](auto& j) { j["end"] = {{"id", "e"}, {"x_m", 100}, {"y_m", 0}}; }),
       {},
       "budget_m"},
      {"end without coordinates", with([](auto& j) { j["end"] = {{"id", "e"}}; }), {}, "end.x_m"},
      {"no budget anywhere", with([](auto& j) { j.erase("budget_m"); }), {}, "budget_m"},
      {"bad budget argument", with([](auto&) {}), {"12abc"}, "BUDGET"},
      {"not JSON", [] { return std::string("{\"schema\": \"mound.sites\", "); }, {}, "bad.json"},
      {"unknown algo", with([](auto&) {}), {"--algo", "magic"}, "--algo"},
      {"unknown option", with([](auto&) {}), {"--fast"}, "--fast"},
      {"negative time limit",
       with([](auto&) {}),
       {"--algo", "alns", "--time-limit", "-1"},
       "--time-limit"},
      {"negative take-off",
       with([](auto& j) { j["takeoff_landing_m"] = -1; }),
       {},
       "takeoff_landing_m"},
      {"scan not an object", with([](auto& j) { j["scan"] = 3; }), {}, "scan"},
      // Fuzzer findings (issue 14): magnitudes that overflowed the cost scaling (x_m 1e155
      // crashed newalg), ids with control characters, a latitude of 1e20.
      {"huge coordinate", with([](auto& j) { j["sites"][0]["x_m"] = 1e155; }), {}, "sites[0].x_m"},
      {"huge home", with([](auto& j) { j["home"]["y_m"] = -1e9; }), {}, "home.y_m"},
      {"huge reward",
       with([](auto& j) { j["sites"][1]["reward"] = 1e300; }),
       {},
       "sites[1].reward"},
      {"huge scan",
       with([](auto& j) { j["sites"][1]["scan_cost_m"] = 1e200; }),
       {},
       "sites[1].scan_cost_m"},
      {"huge budget", with([](auto& j) { j["budget_m"] = 1e300; }), {}, "budget_m"},
      {"control id", with([](auto& j) { j["sites"][2]["id"] = "a\nb"; }), {}, "sites[2].id"},
      {"long id",
       with([](auto& j) { j["sites"][2]["id"] = std::string(300, 'x'); }),
       {},
       "sites[2].id"},
      {"latitude", with([](auto& j) { j["origin"]["lat"] = 1e20; }), {}, "origin.lat"},
      {"origin not object", with([](auto& j) { j["origin"] = 5; }), {}, "origin"},
  };
  for (const BadCase& c : cases) {
    const std::string in = WriteTemp("bad.json", c.text());
    const std::string out = TempPath("never.json");
    std::remove(out.c_str());
    std::vector<std::string> args{in};
    args.insert(args.end(), c.extra.begin(), c.extra.end());
    args.insert(args.end(), {"--out", out});
    const CliRun r = Call(args);
    EXPECT_EQ(r.code, 2) << c.name << ": " << r.err;
    EXPECT_NE(r.err.find(c.must_name), std::string::npos) << c.name << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.name << ": " << r.err;
    EXPECT_FALSE(Exists(out)) << c.name;
    EXPECT_TRUE(r.out.empty()) << c.name;
  }
  EXPECT_EQ(Call({TempPath("does-not-exist.json")}).code, 2);
  EXPECT_EQ(Call({}).code, 2);
}

TEST(PlanCliTest, TakeoffLandingIsPaidOnceAndTheScanIsCarriedAlong) {
  auto j = GoodSites();
  j["takeoff_landing_m"] = 4.0;
  j["scan"] = {{"pattern", "raster"}, {"site_diameter_m", 60}};
  j["sites"] = nlohmann::json::array(
      {{{"id", "a"}, {"x_m", 3}, {"y_m", 4}, {"reward", 1.0}, {"scan_cost_m", 1}}});
  const std::string in = WriteTemp("climb.json", j.dump());
  const CliRun r = Call({in, "100"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto plan = nlohmann::json::parse(r.out);
  // home -> a -> home: 5 + 5 planar, scan 1, take-off and landing 4 once.
  EXPECT_NEAR(plan["cost_m"].get<double>(), 15.0, 1e-9);
  EXPECT_EQ(plan["scan"], j["scan"]);
  EXPECT_EQ(plan["takeoff_landing_m"], 4.0);
  // A path pays it once too (half at home, half at the end node).
  j["end"] = {{"id", "e"}, {"x_m", 6}, {"y_m", 0}};
  const CliRun p = Call({WriteTemp("climb_path.json", j.dump()), "100"});
  ASSERT_EQ(p.code, 0) << p.err;
  EXPECT_NEAR(nlohmann::json::parse(p.out)["cost_m"].get<double>(), 5 + 5 + 1 + 4.0, 1e-9);
  // Too small for the climbs and one site: refused as bad input naming the budget.
  EXPECT_EQ(Call({in, "14"}).code, 2);
}

// sites.json `terrain`: the climb costs of extra_m are added to every leg (the planner
// goes round a costly pair), a path pays path_offset_m once, the block (without its
// matrix) rides into plan.json, and a malformed matrix is refused naming the entry.
TEST(PlanCliTest, TerrainClimbCostsAreAddedToEveryLeg) {
  auto j = GoodSites();
  j["sites"] = nlohmann::json::array({{{"id", "a"}, {"x_m", 3}, {"y_m", 4}, {"reward", 1.0}},
                                      {{"id", "b"}, {"x_m", -3}, {"y_m", 4}, {"reward", 1.0}}});
  // Nodes: home, a, b. home-a 10 m of climbs, home-b 1 m, a-b 50 m.
  j["terrain"] = {{"version", 1},
                  {"nodes", {{{"id", "home"}}, {{"id", "a"}}, {{"id", "b"}}}},
                  {"extra_m", {{0, 10, 1}, {10, 0, 50}, {1, 50, 0}}}};
  const std::string in = WriteTemp("terrain.json", j.dump());
  CliRun r = Call({in, "100", "--algo", "exact"});
  ASSERT_EQ(r.code, 0) << r.err;
  auto plan = nlohmann::json::parse(r.out);
  // Both sites: home-a-b-home = 5 + 6 + 5 planar + 10 + 50 + 1 = 77.
  EXPECT_NEAR(plan["cost_m"].get<double>(), 77.0, 1e-9);
  EXPECT_TRUE(plan["terrain"].is_object());
  EXPECT_FALSE(plan["terrain"].contains("extra_m"));
  // At 70 m only one site fits: b (5 + 5 + 1 + 1 = 12 m) rather than a (5 + 5 + 20 = 30 m),
  // same reward, less cost.
  r = Call({in, "70", "--algo", "exact"});
  ASSERT_EQ(r.code, 0) << r.err;
  plan = nlohmann::json::parse(r.out);
  EXPECT_EQ(plan["tour"], nlohmann::json({"home", "b", "home"}));
  EXPECT_NEAR(plan["cost_m"].get<double>(), 12.0, 1e-9);
  // The default planner agrees.
  r = Call({in, "70"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NEAR(nlohmann::json::parse(r.out)["cost_m"].get<double>(), 12.0, 1e-9);
  // A path home -> e pays the offset once; the budget left accounts for it.
  auto path = j;
  path["end"] = {{"id", "e"}, {"x_m", 0}, {"y_m", 8}};
  path["terrain"]["nodes"] = {{{"id", "home"}}, {{"id", "e"}}, {{"id", "a"}}, {{"id", "b"}}};
  path["terrain"]["extra_m"] = {{0, 0, 10, 1}, {0, 0, 2, 2}, {10, 2, 0, 50}, {1, 2, 50, 0}};
  path["terrain"]["path_offset_m"] = 7.5;
  r = Call({WriteTemp("terrain_path.json", path.dump()), "40", "--algo", "exact"});
  ASSERT_EQ(r.code, 0) << r.err;
  plan = nlohmann::json::parse(r.out);
  // home-b-e: 5 + 1 + 5 + 2 = 13, plus 7.5; home-a-e: 5 + 10 + 5 + 2 + 7.5 = 29.5.
  EXPECT_EQ(plan["tour"], nlohmann::json({"home", "b", "e"}));
  EXPECT_NEAR(plan["cost_m"].get<double>(), 20.5, 1e-9);
  EXPECT_NEAR(plan["budget_m"].get<double>(), 40.0, 1e-9);
  EXPECT_NEAR(plan["budget_left_m"].get<double>(), 19.5, 1e-9);
  struct Bad {
    std::function<void(nlohmann::json&)> edit;
    std::string field;
  };
  const std::vector<Bad> bad = {
      {[](nlohmann::json& d) { d["terrain"]["extra_m"][1][2] = 49; }, "terrain.extra_m[2][1]"},
      {[](nlohmann::json& d) { d["terrain"]["extra_m"][0][0] = 1; }, "terrain.extra_m[0][0]"},
      {[](nlohmann::json& d) { d["terrain"]["extra_m"][2][0] = -1; }, "terrain.extra_m[2][0]"},
      {[](nlohmann::json& d) { d["terrain"]["extra_m"].erase(2); }, "terrain.extra_m"},
      {[](nlohmann::json& d) { d["terrain"]["nodes"][1]["id"] = "b"; }, "terrain.nodes[1].id"},
      {[](nlohmann::json& d) { d["terrain"]["version"] = 2; }, "terrain.version"},
      {[](nlohmann::json& d) { d["terrain"]["path_offset_m"] = 3; }, "terrain.path_offset_m"},
  };
  for (const auto& c : bad) {
    auto d = j;
    c.edit(d);
    const CliRun e = Call({WriteTemp("terrain_bad.json", d.dump()), "100"});
    EXPECT_EQ(e.code, 2) << c.field;
    EXPECT_NE(e.err.find(c.field), std::string::npos) << c.field << ": " << e.err;
  }
}

// --flights K: plan.json's flights[] (always present), each within the budget, no site in
// two, ordered by reward, summing to the top-level reward and cost; one flight is today's
// plan; the exact DP and a baseline flight by flight; bad K refused.
TEST(PlanCliTest, SeveralFlights) {
  auto j = GoodSites();
  j["sites"] = nlohmann::json::array();
  for (int i = 0; i < 12; ++i) {
    j["sites"].push_back({{"id", "s" + std::to_string(i)},
                          {"x_m", (i % 4) * 3.0 - 4},
                          {"y_m", (i / 4) * 3.0 - 3},
                          {"reward", 1.0 + 0.1 * i}});
  }
  const std::string in = WriteTemp("flights.json", j.dump());
  const CliRun one = Call({in, "20"});
  const CliRun k1 = Call({in, "20", "--flights", "1"});
  ASSERT_EQ(one.code, 0) << one.err;
  ASSERT_EQ(k1.code, 0) << k1.err;
  const auto p1 = nlohmann::json::parse(one.out), q1 = nlohmann::json::parse(k1.out);
  EXPECT_EQ(p1["tour"], q1["tour"]);
  ASSERT_EQ(p1["flights"].size(), 1u);
  EXPECT_EQ(p1["flights"][0]["tour"], p1["tour"]);
  EXPECT_NEAR(p1["flights"][0]["budget_left_m"].get<double>(), p1["budget_left_m"].get<double>(),
              1e-9);
  for (const std::string algo : {"alns", "exact", "newalg", "greedy"}) {
    const CliRun r = Call({in, "20", "--flights", "3", "--algo", algo});
    ASSERT_EQ(r.code, 0) << algo << ": " << r.err;
    const auto p = nlohmann::json::parse(r.out);
    ASSERT_EQ(p["flights"].size(), 3u) << algo;
    std::set<std::string> seen;
    double reward = 0, cost = 0, prev = 1e300;
    for (const auto& f : p["flights"]) {
      EXPECT_LE(f["cost_m"].get<double>(), 20 + 1e-9) << algo;
      EXPECT_GE(f["budget_left_m"].get<double>(), -1e-9) << algo;
      EXPECT_LE(f["reward"].get<double>(), prev + 1e-12) << algo;
      prev = f["reward"].get<double>();
      reward += f["reward"].get<double>();
      cost += f["cost_m"].get<double>();
      const auto& t = f["tour"];
      EXPECT_EQ(t.front(), "home");
      EXPECT_EQ(t.back(), "home");
      for (size_t i = 1; i + 1 < t.size(); ++i) EXPECT_TRUE(seen.insert(t[i]).second) << algo;
    }
    EXPECT_NEAR(p["reward"].get<double>(), reward, 1e-9) << algo;
    EXPECT_NEAR(p["cost_m"].get<double>(), cost, 1e-9) << algo;
    EXPECT_EQ(p["tour"], p["flights"][0]["tour"]) << algo;
    EXPECT_GT(reward, p1["reward"].get<double>()) << algo;  // three flights see more
  }
  const double exact =
      nlohmann::json::parse(Call({in, "20", "--flights", "3", "--algo", "exact"}).out)["reward"];
  const double alns = nlohmann::json::parse(Call({in, "20", "--flights", "3"}).out)["reward"];
  EXPECT_NEAR(alns, exact, 1e-9);
  for (const std::string bad : {"0", "65", "x", "-1"}) {
    const CliRun r = Call({in, "20", "--flights", bad});
    EXPECT_EQ(r.code, 2) << bad;
    EXPECT_NE(r.err.find("--flights"), std::string::npos) << r.err;
  }
}

TEST(PlanCliTest, HelpAnywhereOnTheCommandLinePrintsTheUsage) {
  for (const std::vector<std::string>& args : {std::vector<std::string>{"--help"},
                                               {"sites.json", "--help"},
                                               {"tsp", "x.tsp", "-h"},
                                               {"op", "--seed", "nonsense", "--help"}}) {
    const CliRun r = Call(args);
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("usage: mound_plan"), std::string::npos);
    // Every option any command accepts is in the usage text.
    for (const char* opt : {"--algo", "--seed", "--iterations", "--time-limit", "--routes", "--out",
                            "--runs", "--trials", "--optimum", "--kick-segment", "--initial-period",
                            "--ascent-candidates", "--version"}) {
      EXPECT_NE(r.out.find(opt), std::string::npos) << opt;
    }
  }
}

TEST(PlanCliTest, TspCommandPrintsLengthAndOneBasedTour) {
  const CliRun r =
      Call({"tsp", std::string(MOUND_SHARED_DATA) + "/tsplib/eil51.tsp", "--seed", "3"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["length"], 426);
  ASSERT_EQ(j["tour"].size(), 51u);
  std::vector<int> ids = j["tour"].get<std::vector<int>>();
  std::sort(ids.begin(), ids.end());
  for (int i = 0; i < 51; ++i) EXPECT_EQ(ids[i], i + 1);
  EXPECT_EQ(Call({"tsp", "/nonexistent.tsp"}).code, 2);
  // The bounded ascent of large instances, asked for on a small one: still the optimum.
  const std::string eil51 = std::string(MOUND_SHARED_DATA) + "/tsplib/eil51.tsp";
  const CliRun b = Call({"tsp", eil51, "--initial-period", "20", "--ascent-candidates", "8"});
  ASSERT_EQ(b.code, 0) << b.err;
  EXPECT_EQ(nlohmann::json::parse(b.out)["length"], 426);
  const CliRun bad = Call({"tsp", eil51, "--ascent-candidates", "2"});
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("--ascent-candidates"), std::string::npos) << bad.err;
}

TEST(PlanCliTest, OpCommandSolvesOplibWithinTheCostLimit) {
  const std::string file =
      std::string(MOUND_SHARED_DATA) + "/oplib/instances/gen1/gr48-gen1-50.oplib";
  const CliRun r = Call({"op", file, "--algo", "newalg"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const auto inst = tsp::ReadTsplib(file);
  const std::vector<int> tour = j["tour"].get<std::vector<int>>();
  ASSERT_GE(tour.size(), 2u);
  EXPECT_EQ(tour.front(), 1);  // the depot
  EXPECT_EQ(tour.back(), 1);
  // OPLib's objective counts every node on the tour once, the depot included.
  double cost = 0, reward = inst.scores[inst.depot];
  for (size_t i = 0; i + 1 < tour.size(); ++i) {
    cost += static_cast<double>(inst.problem->Dist(tour[i] - 1, tour[i + 1] - 1));
    if (i > 0) reward += inst.scores[tour[i] - 1];
  }
  EXPECT_EQ(j["depot_score"].get<double>(), inst.scores[inst.depot]);
  EXPECT_LE(cost, inst.cost_limit);
  EXPECT_DOUBLE_EQ(j["cost"].get<double>(), cost);
  EXPECT_DOUBLE_EQ(j["reward"].get<double>(), reward);
  EXPECT_GT(reward, 0);
  EXPECT_EQ(Call({"op", file, "--algo", "glv"}).code, 2);  // needs planar coordinates
  EXPECT_EQ(Call({"op", std::string(MOUND_SHARED_DATA) + "/tsplib/eil51.tsp"}).code, 2);
}

// Fuzzer findings (issue 14) on TSPLIB/OPLib input: each exits 2 with one line naming the
// file (and line) instead of crashing, answering with nodes that do not exist, overflowing
// the integer costs or allocating a matrix the file does not hold.
TEST(PlanCliTest, HostileTsplibAndOplibFilesExitTwo) {
  const std::string op_head =
      "NAME: t\nTYPE: OP\nDIMENSION: 8\nEDGE_WEIGHT_TYPE: EUC_2D\nCOST_LIMIT: 30\n"
      "NODE_COORD_SECTION\n1 0 0\n2 1 0\n3 2 0\n4 3 0\n4.5 4 0\n";
  std::string coords8;
  for (int k = 1; k <= 8; ++k) coords8 += std::to_string(k) + " " + std::to_string(k) + " 0\n";
  std::string scores8;
  for (int k = 1; k <= 8; ++k) scores8 += std::to_string(k) + " " + std::to_string(k % 3) + "\n";
  auto op_file = [&](const std::string& depot, const std::string& extra = "") {
    return "NAME: t\nTYPE: OP\nDIMENSION: 8\nEDGE_WEIGHT_TYPE: EUC_2D\nCOST_LIMIT: 30\n" + extra +
           "NODE_COORD_SECTION\n" + coords8 + "NODE_SCORE_SECTION\n" + scores8 + "DEPOT_SECTION\n" +
           depot + "\nEOF\n";
  };
  struct Case {
    std::string name, command, text, must_name;
  };
  std::string big_explicit =
      "NAME: x\nTYPE: TSP\nDIMENSION: 50000\nEDGE_WEIGHT_TYPE: EXPLICIT\n"
      "EDGE_WEIGHT_FORMAT: FULL_MATRIX\nEDGE_WEIGHT_SECTION\n0 1\n1 0\nEOF\n";
  std::string huge_dim =
      "NAME: x\nTYPE: TSP\nDIMENSION: 10000000\nEDGE_WEIGHT_TYPE: EXPLICIT\n"
      "EDGE_WEIGHT_FORMAT: UPPER_ROW\nEDGE_WEIGHT_SECTION\n1\nEOF\n";
  std::string five =
      "NAME: x\nTYPE: TSP\nDIMENSION: 5\nEDGE_WEIGHT_TYPE: EUC_2D\n"
      "NODE_COORD_SECTION\n1 0 0\n2 5e18 0\n3 1 1\n4 2 2\n5 3 3\nEOF\n";
  std::string berlin = ReadFile(std::string(MOUND_SHARED_DATA) + "/tsplib/berlin52.tsp");
  const size_t at = berlin.find("\n1 ", berlin.find("NODE_COORD_SECTION"));
  ASSERT_NE(at, std::string::npos);
  berlin.replace(at, berlin.find('\n', at + 1) - at, "\n1 1e18 655.0");
  const std::vector<Case> cases = {
      {"depot 1e9", "op", op_file("1000000000\n-1"), "depot"},
      {"depot 0", "op", op_file("0\n-1"), "depot"},
      {"depot 9", "op", op_file("9\n-1"), "depot"},
      {"depot -5", "op", op_file("-5\n-1"), "depot"},
      {"depot 1000", "op", op_file("1000\n-1"), "depot"},
      {"depot fraction", "op", op_file("2.5\n-1"), "depot"},
      {"two depots", "op", op_file("1\n2\n-1"), "DEPOT_SECTION"},
      {"cost limit text", "op",
       op_file("1\n-1").replace(op_file("1\n-1").find("COST_LIMIT: 30"), 14, "COST_LIMIT: abc"),
       "COST_LIMIT"},
      {"fractional node id", "op", op_head, "node id"},
      {"berlin52 with 1e18", "tsp", berlin, "x coordinate"},
      {"5 nodes with 5e18", "tsp", five, "x coordinate"},
      {"explicit 50000", "tsp", big_explicit, "explicit matrix of 50000"},
      {"dimension 1e7", "tsp", huge_dim, "DIMENSION"},
      {"negative weight", "tsp",
       "NAME: x\nTYPE: TSP\nDIMENSION: 3\nEDGE_WEIGHT_TYPE: EXPLICIT\n"
       "EDGE_WEIGHT_FORMAT: UPPER_ROW\nEDGE_WEIGHT_SECTION\n1 -2\n3\nEOF\n",
       "edge weight"},
      {"dimension twice", "tsp", "DIMENSION: 3\nDIMENSION: 4\n", "DIMENSION given twice"},
  };
  for (const Case& c : cases) {
    const std::string in = WriteTemp("hostile.tsp", c.text);
    const std::string out = TempPath("never.json");
    std::remove(out.c_str());
    const CliRun r = Call({c.command, in, "--out", out});
    EXPECT_EQ(r.code, 2) << c.name << ": " << r.err << r.out;
    EXPECT_NE(r.err.find(c.must_name), std::string::npos) << c.name << ": " << r.err;
    EXPECT_NE(r.err.find(in), std::string::npos) << c.name << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.name << ": " << r.err;
    EXPECT_FALSE(Exists(out)) << c.name;
  }
  // The same OP file with a valid depot is solved (the cases above differ in one line).
  const std::string ok = WriteTemp("ok.oplib", op_file("3\n-1"));
  const CliRun r = Call({"op", ok});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["tour"].front(), 3);
}

// --time-limit bounds the whole solve, the subgradient ascent included, and a large
// instance reports its progress on stderr (issue 14: 4,000 nodes with --time-limit 2 took
// 25.8 s, 25.6 s of it in the ascent, in silence).
TEST(PlanCliTest, TspTimeLimitCoversTheAscentAndLargeInstancesReportProgress) {
  std::string text =
      "NAME: r6000\nTYPE: TSP\nDIMENSION: 6000\nEDGE_WEIGHT_TYPE: EUC_2D\n"
      "NODE_COORD_SECTION\n";
  uint64_t x = 88172645463325252ULL;
  auto next = [&x]() {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    return static_cast<int>(x % 100000);
  };
  for (int k = 1; k <= 6000; ++k) {
    const int a = next(), b = next();
    text += std::to_string(k) + " " + std::to_string(a) + " " + std::to_string(b) + "\n";
  }
  const std::string in = WriteTemp("r6000.tsp", text + "EOF\n");
  const CliRun r = Call({"tsp", in, "--time-limit", "1"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  // Stopped by the limit, not by convergence: a full ascent on 6,000 nodes needs thousands
  // of iterations (period n/2 = 3,000 to start with).
  EXPECT_LT(j["stats"]["ascent_iterations"].get<int>(), 3000);
  EXPECT_NE(r.err.find("ascent done"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(stopped at half the time limit)"), std::string::npos) << r.err;
  std::vector<int> ids = j["tour"].get<std::vector<int>>();
  ASSERT_EQ(ids.size(), 6000u);
  std::sort(ids.begin(), ids.end());
  for (int i = 0; i < 6000; ++i) ASSERT_EQ(ids[i], i + 1);
}

}  // namespace
}  // namespace mound::plan

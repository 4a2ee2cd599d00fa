// The verdict pipelines as library functions: the paper's rule at and around its threshold,
// the normal fit, the paper's test end to end on clouds with a known offset, the
// reference-free verdict with the default model on a constructed tumulus and on bare
// ground, the coverage of a clipped rise, and options refused naming the field.
#include "recon/verdict.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "common/error.h"
#include "terrain/synthetic_site.h"

namespace mound::recon {
namespace {

using terrain::testing::SyntheticSite;

TEST(PaperRule, MoundAtOrBelowTheThresholdAndConfidenceInThresholdUnits) {
  // relief 10 m, ratio 0.05: threshold 0.5 m
  const PaperDecision at = PaperRule(0.5, 0.1, 10, 0.05);
  EXPECT_TRUE(at.mound);
  EXPECT_DOUBLE_EQ(at.threshold_m, 0.5);
  EXPECT_DOUBLE_EQ(at.confidence, 0);
  const PaperDecision below = PaperRule(0.125, 0.1, 10, 0.05);
  EXPECT_TRUE(below.mound);
  EXPECT_DOUBLE_EQ(below.confidence, 0.75);
  const PaperDecision above = PaperRule(0.75, 0.1, 10, 0.05);
  EXPECT_FALSE(above.mound);
  EXPECT_DOUBLE_EQ(above.confidence, 0.5);
  EXPECT_DOUBLE_EQ(PaperRule(3.0, 0.1, 10, 0.05).confidence, 1.0);  // capped
  EXPECT_THROW(PaperRule(0.1, 0.1, 10, 0), InputError);
  EXPECT_THROW(PaperRule(0.1, 0.1, 0, 0.05), NoResultError);  // a flat reference
}

TEST(FitNormal, MeanAndStdBelowTheQuantile) {
  std::vector<double> d = {1, 2, 3, 4};
  const NormalFit all = FitNormal(d, 1.0);
  EXPECT_DOUBLE_EQ(all.mu, 2.5);
  EXPECT_DOUBLE_EQ(all.sigma, std::sqrt(1.25));
  for (int i = 0; i < 96; ++i) d.push_back(2.5);
  d.push_back(1000);  // one stray point above the 99th percentile
  EXPECT_NEAR(FitNormal(d, 0.99).mu, 2.5, 1e-12);
  EXPECT_GT(FitNormal(d, 1.0).mu, 10);
}

TEST(PaperTest, ACloudOnItsReferenceIsAMoundAndAShiftedOneIsNot) {
  const std::vector<Eigen::Vector3d> reference = SyntheticSite(6, 40, false, 1);
  std::vector<Eigen::Vector3d> cloud =
      SyntheticSite(6, 40, false, 2);  // the same surface, resampled
  PaperTestOptions o;
  o.icp.init = icp::Init::kNone;
  const PaperVerdict same = PaperTest(cloud, reference, o);
  EXPECT_TRUE(same.decision.mound);
  EXPECT_LT(same.decision.mu_m, 0.1);
  EXPECT_NEAR(same.decision.relief_m, Relief(reference), 1e-12);
  EXPECT_GT(same.decision.relief_m, 6);
  // A scan of bare ground where the reference has its tumulus: ICP cannot make the dome
  // appear.
  std::vector<Eigen::Vector3d> bare_site;
  for (const Eigen::Vector3d& p : SyntheticSite(0, 0, false, 3))
    if ((p.head<2>() - Eigen::Vector2d(5, -3)).norm() < 25) bare_site.push_back(p);
  const PaperVerdict bare = PaperTest(bare_site, reference, o);
  EXPECT_FALSE(bare.decision.mound);
  const nlohmann::json j = PaperVerdictJson(bare, o.threshold_ratio);
  EXPECT_EQ(j["label"], "no_mound");
  EXPECT_EQ(j["measurements"]["compare"]["init"], "none");
  EXPECT_DOUBLE_EQ(j["measurements"]["mu_m"].get<double>(), bare.decision.mu_m);
}

TEST(JudgeSite, TheBuiltInModelsAreTheSparseAndTheDenseClouds) {
  EXPECT_EQ(terrain::BuiltInVerdictModel("sparse"), &terrain::DefaultVerdictModel());
  EXPECT_EQ(terrain::BuiltInVerdictModel("dense"), &terrain::DenseVerdictModel());
  EXPECT_EQ(terrain::BuiltInVerdictModel("verdict_model.json"), nullptr);
  EXPECT_EQ(terrain::DefaultVerdictModel().doc["trained"]["cloud"], "sparse");
  EXPECT_EQ(terrain::DenseVerdictModel().doc["trained"]["cloud"], "dense");
  // the dense model also finds the constructed tumulus (80,000 points over 120 m: about half
  // as dense as densify's cloud of a survey site)
  SiteVerdictOptions o;
  o.radius_m = 40;
  const terrain::VerdictModel& dense = terrain::DenseVerdictModel();
  const SiteVerdict mound = JudgeSite(SyntheticSite(5, 30, false, 4), {0, 0}, o, dense);
  EXPECT_TRUE(mound.mound) << mound.p_mound;
  const SiteVerdict bare = JudgeSite(SyntheticSite(0, 0, false, 5), {0, 0}, o, dense);
  EXPECT_FALSE(bare.mound) << bare.p_mound;
}

TEST(JudgeSite, TheDefaultModelFindsATumulusAndNotBareGround) {
  const terrain::VerdictModel model = terrain::DefaultVerdictModel();
  SiteVerdictOptions o;
  o.radius_m = 40;  // the constructed ground's undulation alone falls ~1 m towards 60 m
  const SiteVerdict mound = JudgeSite(SyntheticSite(5, 30, false, 4), {0, 0}, o, model);
  EXPECT_TRUE(mound.mound) << mound.p_mound;
  ASSERT_TRUE(mound.judged);
  EXPECT_NEAR(mound.detection.judged[*mound.judged].height_m, 5, 0.6);
  EXPECT_EQ(mound.coverage.status, "whole") << mound.coverage.message;
  const SiteVerdict bare = JudgeSite(SyntheticSite(0, 0, false, 5), {0, 0}, o, model);
  EXPECT_FALSE(bare.mound) << bare.p_mound;
  EXPECT_LT(bare.p_mound, mound.p_mound);
  const nlohmann::json j = SiteVerdictJson(mound, model, "default", o.detector);
  EXPECT_EQ(j["label"], "mound");
  EXPECT_EQ(j["measurements"]["judged_rises"].size(), mound.detection.judged.size());
  EXPECT_EQ(j["measurements"]["rise"], j["measurements"]["judged_rises"][*mound.judged]);
  // Unset, the radius is the 80th percentile of the points' distance from the centre: on
  // the 120 m square, pi R^2 = 0.8 x 120^2, R = 60.56 m.
  o.radius_m.reset();
  EXPECT_NEAR(JudgeSite(SyntheticSite(0, 0, false, 6), {0, 0}, o, model).radius_m,
              std::sqrt(0.8 * 14400 / M_PI), 0.5);
}

// A first look in the model's undecided band advises a second, wider flight; that flight,
// judged with the first's p, is decided by both at the second look's threshold.
TEST(JudgeSite, ASecondLookDecidesTheSiteByBothFlightsAtItsThreshold) {
  terrain::VerdictModel model = terrain::DenseVerdictModel();
  SiteVerdictOptions o;
  o.radius_m = 40;
  const std::vector<Eigen::Vector3d> cloud = SyntheticSite(1.5, 20, false, 4);
  const SiteVerdict first = JudgeSite(cloud, {0, 0}, o, model);
  // a band around this site's p
  nlohmann::json doc = model.doc;
  doc["threshold"] = (1 + first.p_mound) / 2;
  doc["second_look"] = {{"p_low", first.p_mound / 2},
                        {"threshold", 0.3},
                        {"scan_factor", 2.0},
                        {"combine", {{"first", 0.25}, {"second", 0.5}, {"bias", 0.0}}}};
  model = terrain::ParseVerdictModel(doc, "m.json");
  const SiteVerdict again = JudgeSite(cloud, {0, 0}, o, model);
  EXPECT_FALSE(again.mound);  // below the first look's threshold
  const nlohmann::json j = SiteVerdictJson(again, model, "m.json", o.detector);
  EXPECT_EQ(j["look"], "first");
  EXPECT_EQ(j["second_look"]["advised"], true);
  EXPECT_EQ(j["second_look"]["scan_factor"], 2.0);
  EXPECT_NE(j["second_look"]["message"].get<std::string>().find("--second-look"),
            std::string::npos);
  o.first_look_p = 0.2;  // the same cloud as the second flight's, a first flight's p 0.2
  const SiteVerdict second = JudgeSite(cloud, {0, 0}, o, model);
  EXPECT_TRUE(second.second_look);
  EXPECT_NEAR(second.model_p, first.p_mound, 1e-12);
  const double logit = std::log(first.p_mound / (1 - first.p_mound));
  EXPECT_NEAR(second.p_mound, 1 / (1 + std::exp(-(0.25 * std::log(0.25) + 0.5 * logit))), 1e-12);
  EXPECT_EQ(second.mound, second.p_mound >= 0.3);
  const nlohmann::json k = SiteVerdictJson(second, model, "m.json", o.detector);
  EXPECT_EQ(k["look"], "second");
  EXPECT_EQ(k["model"]["threshold"], 0.3);
  EXPECT_NEAR(k["model_p_mound"].get<double>(), first.p_mound, 1e-12);
  EXPECT_EQ(k["first_look_p_mound"], 0.2);
  EXPECT_FALSE(k.contains("second_look"));  // no third look
  // a model without a second look cannot judge one
  nlohmann::json one_look = terrain::DefaultVerdictModel().doc;
  one_look.erase("second_look");
  EXPECT_THROW(JudgeSite(cloud, {0, 0}, o, terrain::ParseVerdictModel(one_look, "one.json")),
               InputError);
  o.first_look_p = 1.5;
  EXPECT_THROW(JudgeSite(cloud, {0, 0}, o, model), InputError);
}

// Three answers: with an undecided band in the model, a clear tumulus is a mound, bare
// ground no mound, and a site whose p lies in the band undecided (its two answers beside
// it); --decide-at gives two answers whatever the band; a model without a band decides at
// its threshold as before, and the band is refused out of order.
TEST(JudgeSite, TheUndecidedBandGivesThreeAnswersAndDecideAtTwo) {
  const terrain::VerdictModel& built_in = terrain::DefaultVerdictModel();
  SiteVerdictOptions o;
  o.radius_m = 40;
  const std::vector<Eigen::Vector3d> clear = SyntheticSite(5, 30, false, 4),
                                     bare = SyntheticSite(0, 0, false, 5),
                                     weak = SyntheticSite(0.6, 14, false, 4);
  const double p_weak = JudgeSite(weak, {0, 0}, o, built_in).p_mound;
  const double p_clear = JudgeSite(clear, {0, 0}, o, built_in).p_mound;
  const double p_bare = JudgeSite(bare, {0, 0}, o, built_in).p_mound;
  ASSERT_LT(p_bare, p_weak);
  ASSERT_LT(p_weak, p_clear);
  nlohmann::json doc = built_in.doc;
  doc["undecided"] = {{"p_low", (p_bare + p_weak) / 2}, {"p_high", (p_weak + p_clear) / 2}};
  const terrain::VerdictModel model = terrain::ParseVerdictModel(doc, "band.json");
  ASSERT_TRUE(model.undecided);
  EXPECT_EQ(JudgeSite(clear, {0, 0}, o, model).label, "mound");
  EXPECT_EQ(JudgeSite(bare, {0, 0}, o, model).label, "no_mound");
  const SiteVerdict in_band = JudgeSite(weak, {0, 0}, o, model);
  EXPECT_EQ(in_band.label, "undecided");
  const nlohmann::json j = SiteVerdictJson(in_band, model, "band.json", o.detector);
  EXPECT_EQ(j["label"], "undecided");
  EXPECT_EQ(j["decision"]["rule"], "undecided_band");
  EXPECT_EQ(j["two_answer"]["label"], in_band.p_mound >= model.threshold ? "mound" : "no_mound");
  EXPECT_EQ(j["two_answer"]["threshold"], model.threshold);
  // why: the 0.6 m rise is low; no second look in this model: for the field team
  ASSERT_FALSE(j["undecided"]["reasons"].empty());
  std::vector<std::string> codes;
  for (const auto& r : j["undecided"]["reasons"]) codes.push_back(r["code"]);
  EXPECT_NE(std::find(codes.begin(), codes.end(), "low"), codes.end()) << j["undecided"].dump();
  EXPECT_EQ(j["undecided"]["next"], "field_team");
  EXPECT_FALSE(SiteVerdictJson(JudgeSite(clear, {0, 0}, o, model), model, "band.json", o.detector)
                   .contains("undecided"));
  // the paper's protocol: two answers at P
  SiteVerdictOptions two = o;
  two.decide_at = p_weak / 2;
  const SiteVerdict decided = JudgeSite(weak, {0, 0}, two, model);
  EXPECT_EQ(decided.label, "mound");
  EXPECT_TRUE(decided.mound);
  EXPECT_EQ(SiteVerdictJson(decided, model, "band.json", o.detector)["decision"]["rule"],
            "decide_at");
  two.decide_at = std::nextafter(p_weak, 1.0);
  EXPECT_EQ(JudgeSite(weak, {0, 0}, two, model).label, "no_mound");
  two.decide_at = 1.0;
  EXPECT_THROW(JudgeSite(weak, {0, 0}, two, model), InputError);
  // without the band: the threshold's two answers, as before
  EXPECT_EQ(JudgeSite(weak, {0, 0}, o, built_in).label,
            p_weak >= built_in.threshold ? "mound" : "no_mound");
  for (const auto& [lo, hi] : std::vector<std::pair<double, double>>{
           {0.6, 0.4}, {0.0, 0.5}, {0.5, 1.0}, {std::nan(""), 0.5}}) {
    nlohmann::json bad = built_in.doc;
    bad["undecided"] = {{"p_low", lo}, {"p_high", hi}};
    EXPECT_THROW(terrain::ParseVerdictModel(bad, "bad.json"), InputError) << lo << " " << hi;
  }
  nlohmann::json bad = built_in.doc;
  bad["undecided"] = 0.5;
  EXPECT_THROW(terrain::ParseVerdictModel(bad, "bad.json"), InputError);
  // learned reasons: the weak rise's roughness r named "cut" by thresholds below it and
  // above its "irregular" one, "irregular" by thresholds both below it, neither above it
  const double r = in_band.detection.judged[*in_band.judged].roughness;
  auto codes_of = [&](double cut, double irregular) {
    nlohmann::json d = doc;
    d["reasons"] = {{"cut_roughness", cut}, {"irregular_roughness", irregular}};
    const terrain::VerdictModel m = terrain::ParseVerdictModel(d, "reasons.json");
    std::vector<std::string> out;
    for (const auto& [code, text] : UndecidedReasons(JudgeSite(weak, {0, 0}, o, m), m))
      out.push_back(code);
    return out;
  };
  auto has = [](const std::vector<std::string>& v, const std::string& c) {
    return std::find(v.begin(), v.end(), c) != v.end();
  };
  EXPECT_TRUE(has(codes_of(r / 2, r * 2), "cut"));
  EXPECT_FALSE(has(codes_of(r / 2, r * 2), "irregular"));
  EXPECT_TRUE(has(codes_of(r / 4, r / 2), "irregular"));
  EXPECT_FALSE(has(codes_of(r / 4, r / 2), "cut"));
  EXPECT_FALSE(has(codes_of(r * 2, r * 4), "cut"));
  for (const nlohmann::json& reasons :
       {nlohmann::json(1), nlohmann::json{{"cut_roughness", 0.2}},
        nlohmann::json{{"cut_roughness", 0.3}, {"irregular_roughness", 0.2}},
        nlohmann::json{{"cut_roughness", 0.0}, {"irregular_roughness", 0.2}}}) {
    bad = built_in.doc;
    bad["reasons"] = reasons;
    EXPECT_THROW(terrain::ParseVerdictModel(bad, "bad.json"), InputError) << reasons.dump();
  }
}

// Issue 68: a site on ground outside the model's terrain domain is undecided with reason
// "terrain" whatever its p, and no second look is advised (a wider look at the same unseen
// ground); decide_at keeps the paper's two answers; inside the domain nothing changes.
TEST(JudgeSite, GroundOutsideTheTerrainDomainIsUndecided) {
  nlohmann::json doc = terrain::DenseVerdictModel().doc;
  doc["terrain_domain"] = {{"ranges", {{"site_slope_rad", {0.0, 0.3}}}}, {"sites", 1}};
  const terrain::VerdictModel model = terrain::ParseVerdictModel(doc, "domain.json");
  SiteVerdictOptions o;
  o.radius_m = 40;
  std::vector<Eigen::Vector3d> clear = SyntheticSite(5, 30, false, 4), steep = clear;
  for (Eigen::Vector3d& p : steep) p.z() += std::tan(25 * M_PI / 180) * p.x();
  const SiteVerdict inside = JudgeSite(clear, {0, 0}, o, model);
  EXPECT_EQ(inside.label, "mound");
  EXPECT_TRUE(inside.terrain.empty());
  EXPECT_EQ(SiteVerdictJson(inside, model, "domain.json", o.detector)["terrain"]["status"],
            "inside");
  const SiteVerdict outside = JudgeSite(steep, {0, 0}, o, model);
  EXPECT_GE(outside.p_mound, model.threshold);  // the model alone would call it a mound
  EXPECT_EQ(outside.label, "undecided");
  ASSERT_EQ(outside.terrain.size(), 1u);
  const nlohmann::json j = SiteVerdictJson(outside, model, "domain.json", o.detector);
  EXPECT_EQ(j["terrain"]["status"], "outside");
  EXPECT_EQ(j["terrain"]["outside"][0]["name"], "site_slope_rad");
  EXPECT_EQ(j["undecided"]["reasons"][0]["code"], "terrain");
  const std::string text = j["undecided"]["reasons"][0]["text"];
  std::ostringstream want;  // in degrees, as the field team reads it
  want.precision(3);
  want << "site slope " << outside.detection.site_slope_rad * 180 / M_PI
       << " deg outside its training sites' [0, 17.2]";
  EXPECT_NE(text.find(want.str()), std::string::npos) << text;
  EXPECT_EQ(j["undecided"]["next"], "field_team");
  EXPECT_NEAR(j["measurements"]["terrain"]["site_slope_rad"].get<double>(),
              outside.detection.site_slope_rad, 1e-12);
  SiteVerdictOptions two = o;
  two.decide_at = 0.5;
  EXPECT_EQ(JudgeSite(steep, {0, 0}, two, model).label, "mound");
  // ground each of whose descriptors lies in range, far from the training sites' (the clear
  // site's ground its one point, unit scale): undecided, the distance named
  const std::vector<double> g = terrain::TerrainDescriptors(inside.detection);
  doc["terrain_domain"]["ranges"] = {{"site_slope_rad", {-1.0, 1.0}}};
  std::vector<double> away = g;
  away[1] += 3;  // site_relief_m 3 m more
  doc["terrain_domain"]["neighbours"] = {{"k", 1},
                                         {"centre", std::vector<double>(g.size(), 0.0)},
                                         {"scale", std::vector<double>(g.size(), 1.0)},
                                         {"points", {away}},
                                         {"max_distance", 1.0}};
  const terrain::VerdictModel far = terrain::ParseVerdictModel(doc, "far.json");
  const SiteVerdict unlike = JudgeSite(clear, {0, 0}, o, far);
  EXPECT_EQ(unlike.label, "undecided");
  ASSERT_EQ(unlike.terrain.size(), 1u);
  EXPECT_EQ(unlike.terrain[0].name, "training_distance");
  EXPECT_NEAR(unlike.terrain[0].value, 3, 1e-9);
  const nlohmann::json u = SiteVerdictJson(unlike, far, "far.json", o.detector);
  const std::string why = u["undecided"]["reasons"][0]["text"];
  EXPECT_NE(why.find("from its nearest training sites'"), std::string::npos) << why;
  EXPECT_EQ(SiteVerdictJson(JudgeSite(steep, {0, 0}, o, terrain::DenseVerdictModel()),
                            terrain::DenseVerdictModel(), "dense", o.detector)["terrain"]["status"],
            "unchecked");
}

// A model names the candidate rises it was trained on; a site measured with another set is
// undecided (reason model, no second look), whatever p says; measured with the model's set,
// it is judged. A model without detector.candidates is a site_ground model.
TEST(JudgeSite, CandidatesOtherThanTheModelsAreUndecided) {
  nlohmann::json doc = terrain::DenseVerdictModel().doc;
  doc["detector"] = {{"candidates", "local_relief"}};
  const terrain::VerdictModel local = terrain::ParseVerdictModel(doc, "local.json");
  EXPECT_EQ(local.candidates, terrain::DetectorOptions::Candidates::kLocalRelief);
  EXPECT_EQ(terrain::DenseVerdictModel().candidates,
            terrain::DetectorOptions::Candidates::kSiteGround);
  SiteVerdictOptions o;
  o.radius_m = 40;
  const std::vector<Eigen::Vector3d> cloud = SyntheticSite(5, 30, false, 4);
  const SiteVerdict other = JudgeSite(cloud, {0, 0}, o, local);  // site_ground measured
  EXPECT_TRUE(other.other_candidates);
  EXPECT_GE(other.p_mound, local.threshold);
  EXPECT_EQ(other.label, "undecided");
  const nlohmann::json j = SiteVerdictJson(other, local, "local.json", o.detector);
  EXPECT_EQ(j["undecided"]["reasons"][0]["code"], "model");
  EXPECT_EQ(j["measurements"]["candidates"], "site_ground");
  EXPECT_EQ(j["model"]["candidates"], "local_relief");
  o.detector.candidates = terrain::DetectorOptions::Candidates::kLocalRelief;
  const SiteVerdict same = JudgeSite(cloud, {0, 0}, o, local);
  EXPECT_FALSE(same.other_candidates);
  EXPECT_EQ(same.label, "mound");
  EXPECT_EQ(SiteVerdictJson(same, local, "local.json", o.detector)["measurements"]["candidates"],
            "local_relief");
  for (const nlohmann::json& bad :
       {nlohmann::json("local_relief"), nlohmann::json::object(),
        nlohmann::json{{"candidates", "ridges"}}, nlohmann::json{{"candidates", 1}},
        nlohmann::json{{"candidates", "local_relief"}, {"cell_m", 0.5}}}) {
    doc["detector"] = bad;
    try {
      terrain::ParseVerdictModel(doc, "bad.json");
      ADD_FAILURE() << bad.dump();
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("bad.json: detector", 0), 0u) << e.what();
    }
  }
}

// A torn reconstruction (points strewn hundreds of metres off, as a bad bundle adjustment
// leaves them) reaches beyond what its cameras could see and is not judged; the same site
// whole is.
TEST(JudgeSite, ATornCloudBeyondItsCamerasReachIsNotJudged) {
  const terrain::VerdictModel& model = terrain::DefaultVerdictModel();
  SiteVerdictOptions o;
  for (double x : {-30.0, 0.0, 30.0})
    for (double y : {-30.0, 0.0, 30.0}) o.cameras.emplace_back(x, y, 60.0);  // 60 m up
  // a track reaching 42.4 m, 60 m above the ground: it sees within 42.4 + 120 m
  EXPECT_NEAR(CameraReach(o.cameras, {0, 0}, 0.0), std::hypot(30, 30) + 120, 1e-9);
  EXPECT_NEAR(CameraReach(o.cameras, {0, 0}, 70.0), std::hypot(30, 30), 1e-9);  // above them
  std::vector<Eigen::Vector3d> cloud = SyntheticSite(5, 30, false, 4);
  EXPECT_NO_THROW(JudgeSite(cloud, {0, 0}, o, model));
  const size_t n = cloud.size();
  for (size_t k = 0; k < n / 2; ++k) {  // half the points torn 300-600 m away, 200 m down
    const double a = 0.01 * static_cast<double>(k);
    cloud[k] = Eigen::Vector3d(std::cos(a), std::sin(a), 0) * (300 + static_cast<double>(k % 300)) +
               Eigen::Vector3d(0, 0, -200);
  }
  try {
    JudgeSite(cloud, {0, 0}, o, model);
    ADD_FAILURE() << "judged a torn cloud";
  } catch (const NoResultError& e) {
    EXPECT_NE(std::string(e.what()).find("torn reconstruction"), std::string::npos) << e.what();
  }
  o.radius_m = 40;  // a radius given: the site is the user's, not the cloud's extent
  EXPECT_NO_THROW(JudgeSite(cloud, {0, 0}, o, model));
}

TEST(JudgeCoverage, AClippedRiseAsksForAWiderScan) {
  terrain::Detection d;
  terrain::Rise r;
  r.clipped = 0.3;
  r.extent_m = 28;
  d.judged = {r};
  const Coverage c = JudgeCoverage(d, &d.judged[0], 25);
  EXPECT_EQ(c.status, "clipped");
  EXPECT_DOUBLE_EQ(c.scan_needed_m, 70);  // 2.5 x 28 = 70
  EXPECT_NE(c.message.find("runs off the scanned site"), std::string::npos);
  d.site_sag_m = 1.5;  // domed all over (a plane ground fit): at least 4 x the radius
  EXPECT_DOUBLE_EQ(JudgeCoverage(d, nullptr, 25).scan_needed_m, 100);
  // A quadratic ground fit that stays level: the tumulus inside the scan domes the site,
  // the ground around it was seen.
  d.ground_coefficients = {50, 0.01, 0, -1e-5, 0, -1e-5};
  d.ground_sag_m = 0.01;
  EXPECT_EQ(JudgeCoverage(d, nullptr, 25).status, "no_rise");
  d.ground_sag_m = 0.8;  // the ground fit bends with the dome: no ground in sight
  EXPECT_EQ(JudgeCoverage(d, nullptr, 25).status, "clipped");
  d.site_sag_m = 0;
  EXPECT_EQ(JudgeCoverage(d, nullptr, 25).status, "no_rise");
  r.clipped = 0.05;
  EXPECT_EQ(JudgeCoverage(d, &r, 25).status, "whole");
}

TEST(Options, RefusedNamingTheField) {
  SiteVerdictOptions s;
  s.radius_m = -1;
  EXPECT_THROW(s.Check(), InputError);
  s.radius_m.reset();
  s.detector.ground_order = 3;
  try {
    s.Check();
    ADD_FAILURE() << "ground order 3 accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("detector.ground_order:", 0), 0u);
  }
  PaperTestOptions p;
  p.threshold_ratio = 0;
  EXPECT_THROW(p.Check(), InputError);
  p.threshold_ratio = 0.05;
  p.icp.max_source_points = 3;
  EXPECT_THROW(p.Check(), InputError);
}

}  // namespace
}  // namespace mound::recon

// Unit tests of the wire conversions: what a request may carry, and that no
// reply carries a NaN or an infinity marked resolved.
#include "proto/weavefit/v1/convert.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>
#include <string>
#include <utility>

namespace weavefit {
namespace {

// The numbers of a measurement a client reads when it is resolved.
bool AllFinite(const v1::Measurement& m) {
  return std::isfinite(m.value()) && std::isfinite(m.stderr()) && std::isfinite(m.statistical()) &&
         std::isfinite(m.systematic()) && std::isfinite(m.systematic_common()) &&
         std::isfinite(m.upper_bound());
}

int WarningsNaming(const google::protobuf::RepeatedPtrField<std::string>& warnings,
                   const std::string& field) {
  int n = 0;
  for (const std::string& w : warnings) n += w.rfind(field + " came out as", 0) == 0;
  return n;
}

// Any stage that lets a NaN or an infinity through is caught at the reply:
// the quantity goes out unresolved with a warning naming it, the sound ones
// as they were (issue 30: a 1e-300 mm cylinder gave NaN errors, resolved).
TEST(ReplyFromEstimateTest, ANonFiniteQuantityGoesOutUnresolvedWithAWarning) {
  Estimate e;
  e.peak_spacing_rad = {0.3, std::nan(""), true};
  e.max_slope = {INFINITY, 0.01, true};
  e.wavelength_mm = {1.0, 0.01, true, 0.0, std::nan("")};
  e.amplitude_mm = {1e150, 1e149, true};  // absurd but finite: sent as it is
  e.specular_azimuth_rad = {1e307, 0.001, true};  // overflows to infinity in degrees
  e.max_inclination_rad = {0.0, 0.0, false, INFINITY};  // an unbounded bound: none
  ChannelSummary green;
  green.channel = "G";
  green.peak_spacing_rad = {std::nan(""), 0.1, true};
  green.specular_azimuth_rad = {0.1, 0.01, true};
  e.channels = {green};
  e.warnings = {"a warning of the estimate"};
  const v1::EstimateReply reply = ReplyFromEstimate(e, "nan");

  for (const v1::Measurement& m :
       {reply.peak_spacing_deg(), reply.max_slope(), reply.wavelength_mm(),
        reply.specular_azimuth_deg(), reply.channels(0).peak_spacing_deg()}) {
    EXPECT_FALSE(m.resolved()) << m.DebugString();
    EXPECT_TRUE(AllFinite(m)) << m.DebugString();
  }
  EXPECT_TRUE(reply.amplitude_mm().resolved());
  EXPECT_TRUE(AllFinite(reply.amplitude_mm()));
  EXPECT_TRUE(reply.channels(0).specular_azimuth_deg().resolved());
  EXPECT_EQ(reply.max_inclination_deg().upper_bound(), 0.0);
  EXPECT_FALSE(reply.max_inclination_deg().resolved());

  ASSERT_EQ(reply.warnings_size(), 6);
  EXPECT_EQ(reply.warnings(0), "a warning of the estimate");
  for (const char* field : {"peak_spacing_deg", "max_slope", "wavelength_mm",
                            "specular_azimuth_deg", "channels[G].peak_spacing_deg"}) {
    EXPECT_EQ(WarningsNaming(reply.warnings(), field), 1) << field;
  }
  EXPECT_NE(reply.warnings(1).find("Check the acquisition metadata"), std::string::npos);
}

TEST(JointToProtoTest, ANonFiniteQuantityGoesOutUnresolvedWithAWarning) {
  JointEstimate joint;
  joint.max_slope = {0.2, std::nan(""), true};
  joint.wavelength_mm = {1.0, 0.01, true};
  const v1::JointEstimate out = JointToProto(joint, {"a.png"});
  EXPECT_FALSE(out.max_slope().resolved());
  EXPECT_TRUE(AllFinite(out.max_slope()));
  EXPECT_TRUE(out.wavelength_mm().resolved());
  ASSERT_EQ(out.warnings_size(), 1);
  EXPECT_EQ(WarningsNaming(out.warnings(), "max_slope"), 1);
}

// The ranges are Acquisition::Validate's alone: the wire adds no copy of
// them, and a NaN phase angle is refused there too.
TEST(AcquisitionFromProtoTest, RangesAreTheLibrarysAndNameTheWireField) {
  v1::Acquisition proto;
  proto.set_phase_angle_deg(10.0);
  EXPECT_TRUE(AcquisitionFromProto(proto).ok());  // diameter 0 = 46 mm
  for (double diameter : {1e-300, 1e300, -1.0}) {
    proto.set_cylinder_diameter_mm(diameter);
    const absl::StatusOr<Acquisition> a = AcquisitionFromProto(proto);
    ASSERT_FALSE(a.ok()) << diameter;
    EXPECT_EQ(a.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_EQ(std::string(a.status().message()).rfind("cylinder_diameter_mm", 0), 0u);
  }
  proto.set_cylinder_diameter_mm(46.0);
  proto.set_phase_angle_deg(std::nan(""));
  const absl::StatusOr<Acquisition> a = AcquisitionFromProto(proto);
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(std::string(a.status().message()).rfind("phase_angle_deg", 0), 0u);
}

// A given cylinder crosses the wire and back unchanged (degrees ↔
// radians); a 0 error is the default, 0.5 px; its fields are checked by the
// library, naming the wire field; DETECTED is not a cylinder one can give.
TEST(GivenCylinderProtoTest, RoundTripDefaultsAndChecks) {
  GivenCylinder given;
  given.center_x_px = 159.5;
  given.radius_px = 128.25;
  given.axis_angle_rad = 1.5 * M_PI / 180.0;
  given.radius_stderr_px = 0.125;
  given.center_stderr_px = 0.25;
  given.lens_blur_px = 0.75;
  given.source = CylinderSource::kShared;
  v1::Acquisition proto;
  proto.set_phase_angle_deg(10.0);
  *proto.mutable_given_cylinder() = GivenCylinderToProto(given);
  EXPECT_EQ(proto.given_cylinder().source(), v1::SHARED);
  absl::StatusOr<Acquisition> a = AcquisitionFromProto(proto);
  ASSERT_TRUE(a.ok()) << a.status();
  ASSERT_TRUE(a->given_cylinder.has_value());
  EXPECT_EQ(a->given_cylinder->center_x_px, 159.5);
  EXPECT_EQ(a->given_cylinder->radius_px, 128.25);
  EXPECT_NEAR(a->given_cylinder->axis_angle_rad, given.axis_angle_rad, 1e-15);
  EXPECT_EQ(a->given_cylinder->radius_stderr_px, 0.125);
  EXPECT_EQ(a->given_cylinder->center_stderr_px, 0.25);
  EXPECT_EQ(a->given_cylinder->lens_blur_px, 0.75);
  EXPECT_EQ(a->given_cylinder->source, CylinderSource::kShared);
  EXPECT_NEAR(GivenCylinderToProto(*a->given_cylinder).axis_angle_deg(), 1.5, 1e-12);

  // Unset: detect. Set with defaults: GIVEN, 0.5 px.
  proto.clear_given_cylinder();
  a = AcquisitionFromProto(proto);
  ASSERT_TRUE(a.ok());
  EXPECT_FALSE(a->given_cylinder.has_value());
  proto.mutable_given_cylinder()->set_center_x_px(160.0);
  proto.mutable_given_cylinder()->set_radius_px(100.0);
  a = AcquisitionFromProto(proto);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_EQ(a->given_cylinder->radius_stderr_px, GivenCylinder::kDefaultStderrPx);
  EXPECT_EQ(a->given_cylinder->center_stderr_px, GivenCylinder::kDefaultStderrPx);
  EXPECT_EQ(a->given_cylinder->source, CylinderSource::kGiven);

  for (const auto& [field, set] :
       std::vector<std::pair<std::string, std::function<void(v1::GivenCylinder*)>>>{
           {"given_cylinder.radius_px", [](v1::GivenCylinder* g) { g->set_radius_px(-1.0); }},
           {"given_cylinder.center_x_px",
            [](v1::GivenCylinder* g) { g->set_center_x_px(std::nan("")); }},
           {"given_cylinder.axis_angle_deg",
            [](v1::GivenCylinder* g) { g->set_axis_angle_deg(90.0); }},
           {"given_cylinder.lens_blur_px", [](v1::GivenCylinder* g) { g->set_lens_blur_px(-1); }},
           {"given_cylinder.source", [](v1::GivenCylinder* g) { g->set_source(v1::DETECTED); }},
           {"given_cylinder.source",
            [](v1::GivenCylinder* g) { g->set_source(static_cast<v1::CylinderSource>(9)); }}}) {
    v1::Acquisition bad = proto;
    set(bad.mutable_given_cylinder());
    const absl::StatusOr<Acquisition> refused = AcquisitionFromProto(bad);
    ASSERT_FALSE(refused.ok()) << field;
    EXPECT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_EQ(std::string(refused.status().message()).rfind(field, 0), 0u)
        << refused.status();
  }
}

TEST(ReplyFromEstimateTest, TheCylindersSourceIsSaid) {
  Estimate e;
  EXPECT_EQ(ReplyFromEstimate(e, "x").cylinder().source(), v1::DETECTED);
  e.cylinder_source = CylinderSource::kGiven;
  EXPECT_EQ(ReplyFromEstimate(e, "x").cylinder().source(), v1::GIVEN);
  e.cylinder_source = CylinderSource::kShared;
  const v1::EstimateReply reply = ReplyFromEstimate(e, "x");
  EXPECT_EQ(reply.cylinder().source(), v1::SHARED);
  EXPECT_NE(ReplyToJson(reply).find("\"source\": \"SHARED\""), std::string::npos)
      << ReplyToJson(reply);
}

// MODE_UNSPECIFIED is the server's default; a value the enum does not know
// is refused, not run as BALANCED (issue 30).
TEST(OptionsFromProtoTest, UnknownModesAreInvalidArgument) {
  EstimateOptions base;
  base.mode = Mode::kFast;  // what the options come on top of
  v1::EstimateOptions proto;
  const std::pair<int, Mode> known[] = {{v1::MODE_UNSPECIFIED, Mode::kBalanced},
                                        {v1::FAST, Mode::kFast},
                                        {v1::BALANCED, Mode::kBalanced},
                                        {v1::ACCURATE, Mode::kAccurate}};
  for (const auto& [wire, mode] : known) {
    proto.set_mode(static_cast<v1::Mode>(wire));
    const absl::StatusOr<EstimateOptions> options = OptionsFromProto(proto, base);
    ASSERT_TRUE(options.ok()) << wire << ": " << options.status();
    EXPECT_EQ(options->mode, mode) << wire;
  }
  for (int wire : {99, -1, 4}) {
    proto.set_mode(static_cast<v1::Mode>(wire));
    const absl::StatusOr<EstimateOptions> options = OptionsFromProto(proto, base);
    ASSERT_FALSE(options.ok()) << wire;
    EXPECT_EQ(options.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_EQ(std::string(options.status().message()),
              "options.mode " + std::to_string(wire) +
                  " is not a known mode (FAST, BALANCED, ACCURATE)");
  }
}

}  // namespace
}  // namespace weavefit

// The CreateSurvey request for a simulated light scene (its camera and reference lights),
// shared by the survey integration test and the survey benchmark.
#pragma once

#include <cstdint>
#include <map>
#include <opencv2/core.hpp>
#include <string>

#include "tests/data/light_scene.h"
#include "texfree/v1/survey.pb.h"

namespace texfree::testing {

// Intrinsics from scene.camera; `references` (id -> position in metres) as the surveyed
// reference lights.
v1::CreateSurveyRequest SurveyRequestFor(const testdata::LightScene& scene,
                                         const std::map<uint32_t, cv::Point3d>& references,
                                         const std::string& name);

}  // namespace texfree::testing

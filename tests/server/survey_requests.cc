// SurveyRequestFor implementation.
#include "tests/server/survey_requests.h"

namespace texfree::testing {

v1::CreateSurveyRequest SurveyRequestFor(const testdata::LightScene& scene,
                                         const std::map<uint32_t, cv::Point3d>& references,
                                         const std::string& name) {
  v1::CreateSurveyRequest request;
  request.set_name(name);
  auto* in = request.mutable_intrinsics();
  in->set_fx(scene.camera.K(0, 0));
  in->set_fy(scene.camera.K(1, 1));
  in->set_cx(scene.camera.K(0, 2));
  in->set_cy(scene.camera.K(1, 2));
  for (double d : scene.camera.distortion) in->add_distortion(d);
  in->set_width(scene.camera.size.width);
  in->set_height(scene.camera.size.height);
  for (const auto& [id, X] : references) {
    auto* r = request.add_references();
    r->set_id(id);
    r->mutable_position_m()->set_x(X.x);
    r->mutable_position_m()->set_y(X.y);
    r->mutable_position_m()->set_z(X.z);
  }
  return request;
}

}  // namespace texfree::testing

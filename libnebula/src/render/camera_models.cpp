// SPDX-License-Identifier: Apache-2.0
/// @file camera_models.cpp
/// The registered camera models (render/camera_model.h), in the order of --camera's help.
/// Adding a camera: its file src/render/camera_<name>.cpp defining `const CameraModel&
/// <name>Camera()`, and one line here.
#include "nebula/render/camera_model.h"

#define NEBULA_CAMERAS(X)                                                                          \
    X(perspective)                                                                                 \
    X(fisheye)                                                                                     \
    X(equirect)                                                                                    \
    X(orthographic)                                                                                \
    X(ods)                                                                                         \
    X(fisheyeStereo)

namespace nebula {

#define NEBULA_DECLARE_CAMERA(name) const CameraModel& name##Camera();
NEBULA_CAMERAS(NEBULA_DECLARE_CAMERA)
#undef NEBULA_DECLARE_CAMERA

const std::vector<const CameraModel*>& cameraModels()
{
#define NEBULA_LIST_CAMERA(name) &name##Camera(),
    static const std::vector<const CameraModel*> models{NEBULA_CAMERAS(NEBULA_LIST_CAMERA)};
#undef NEBULA_LIST_CAMERA
    return models;
}

} // namespace nebula

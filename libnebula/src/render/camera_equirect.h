// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file camera_equirect.h
/// Internal to render/: the latitude-longitude panorama's mapping (camera_equirect.cpp),
/// which omni-directional stereo (camera_ods.cpp) uses for each eye.

#include "nebula/render/camera_model.h"

namespace nebula::detail {

/// A W x H/views panorama per view, the views stacked (the left eye's on top), the view
/// direction at each one's centre.
class EquirectProjection : public CameraProjection
{
public:
    EquirectProjection(const Camera& c, int views);

    bool direction(double px, double py, Vec3& d) const override;
    double pixelSolidAngle(double px, double py) const override;
    bool project(const Vec3& p, double& px, double& py, int view) const override;
    bool wrapsHorizontally() const override { return true; }
    int views() const override { return mViews; }
    void viewRows(int view, int& y0, int& y1) const override;

protected:
    /// The view of image row @p py, the row within it and the view's height [pixels].
    int panoramaRow(double py, double& local, double& viewHeight) const;
    int mViews;
};

} // namespace nebula::detail

#pragma once
// The VTK window of the apps: a PCLVisualizer that works on screen or off-screen (under
// `xvfb-run -a`, without an interactor), camera framing, and PNG screenshots.
#include <pcl/visualization/pcl_visualizer.h>

#include <string>
#include <vector>

class vtkRenderer;

namespace pclx {
namespace apps {

// Off-screen: no interactor (PCLVisualizer::saveScreenshot crashes without one) and
// off-screen rendering. Either way without PCL's FPS counter, which would otherwise be
// burnt into screenshots.
pcl::visualization::PCLVisualizer::Ptr makeVisualizer (const std::string& name, bool offscreen, int width,
                                                        int height);

// PCLVisualizer::initCameraParameters, keeping the window's size: PCL's default camera
// carries its own window size and applies it (our screenshots came out 640 x 512 whatever
// --width/--height said).
void initCamera (pcl::visualization::PCLVisualizer& viewer);

// The renderer of a viewport created with createViewPort (0: the first one).
vtkRenderer* viewportRenderer (pcl::visualization::PCLVisualizer& viewer, int viewport);

// Moves the viewport's camera along its view direction (direction and up kept) so the
// subject fills the view with `margin` (a share of the half-width) to spare, and centres
// it. The subject: the points of the named clouds and shapes, or of every visible prop
// when `ids` is empty. 2D text is ignored. Clipping range refitted.
void frameViewport (pcl::visualization::PCLVisualizer& viewer, int viewport, double margin = 0.05,
                    const std::vector<std::string>& ids = {});

// Renders and writes the window to a PNG (vtkWindowToImageFilter + vtkPNGWriter); throws
// std::runtime_error when the file was not written.
void saveScreenshot (pcl::visualization::PCLVisualizer& viewer, const std::string& png);

}  // namespace apps
}  // namespace pclx

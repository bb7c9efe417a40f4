#include <pclx/apps/view.h>

#include <vtkActor.h>
#include <vtkActorCollection.h>
#include <vtkCamera.h>
#include <vtkDataSet.h>
#include <vtkLogger.h>
#include <vtkMapper.h>
#include <vtkMatrix4x4.h>
#include <vtkPNGWriter.h>
#include <vtkPoints.h>
#include <vtkPointSet.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkRendererCollection.h>
#include <vtkWindowToImageFilter.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <stdexcept>

namespace pclx {
namespace apps {

namespace {

// World coordinates of an actor's points (every `stride`-th of large clouds).
void
collectPoints (vtkActor* actor, std::vector<Eigen::Vector3d>& out)
{
  if (!actor || !actor->GetVisibility () || !actor->GetMapper ())
    return;
  vtkDataSet* data = actor->GetMapper ()->GetInput ();
  if (!data || data->GetNumberOfPoints () == 0)
    return;
  vtkSmartPointer<vtkMatrix4x4> m = vtkSmartPointer<vtkMatrix4x4>::New ();
  actor->GetMatrix (m);
  const vtkIdType n = data->GetNumberOfPoints ();
  const vtkIdType stride = std::max<vtkIdType> (1, n / 200000);
  for (vtkIdType i = 0; i < n; i += stride)
  {
    double p[4] = {0, 0, 0, 1}, q[4];
    data->GetPoint (i, p);
    p[3] = 1;
    m->MultiplyPoint (p, q);
    if (std::isfinite (q[0]) && std::isfinite (q[1]) && std::isfinite (q[2]))
      out.emplace_back (q[0], q[1], q[2]);
  }
}

}  // namespace

pcl::visualization::PCLVisualizer::Ptr
makeVisualizer (const std::string& name, bool offscreen, int width, int height)
{
  // VTK 9.1's vtkOpenGLPolyDataMapper::ShallowCopy, which PCL's LOD actors call on their
  // first render, logs six "was deprecated for VTK 9.0" warnings per cloud: developer
  // noise about VTK's own code. VTK errors still reach stderr.
  vtkLogger::SetStderrVerbosity (vtkLogger::VERBOSITY_ERROR);
  pcl::visualization::PCLVisualizer::Ptr viewer (new pcl::visualization::PCLVisualizer (name, !offscreen));
  if (offscreen)
    viewer->getRenderWindow ()->SetOffScreenRendering (1);
  viewer->setShowFPS (false);
  viewer->setSize (width, height);
  return viewer;
}

void
initCamera (pcl::visualization::PCLVisualizer& viewer)
{
  const int* size = viewer.getRenderWindow ()->GetSize ();
  const int width = size[0], height = size[1];
  viewer.initCameraParameters ();
  viewer.setSize (width, height);
}

vtkRenderer*
viewportRenderer (pcl::visualization::PCLVisualizer& viewer, int viewport)
{
  auto renderers = viewer.getRendererCollection ();
  renderers->InitTraversal ();
  int i = 0;
  while (vtkRenderer* r = renderers->GetNextItem ())
    if (i++ == viewport)
      return r;
  throw std::runtime_error ("no viewport " + std::to_string (viewport));
}

void
frameViewport (pcl::visualization::PCLVisualizer& viewer, int viewport, double margin,
               const std::vector<std::string>& ids)
{
  vtkRenderer* ren = viewportRenderer (viewer, viewport);
  std::vector<Eigen::Vector3d> points;
  if (ids.empty ())
  {
    vtkActorCollection* actors = ren->GetActors ();
    actors->InitTraversal ();
    while (vtkActor* a = actors->GetNextActor ())
      collectPoints (a, points);
  }
  else
  {
    const auto clouds = viewer.getCloudActorMap ();
    const auto shapes = viewer.getShapeActorMap ();
    for (const auto& id : ids)
    {
      const auto c = clouds->find (id);
      if (c != clouds->end ())
        collectPoints (c->second.actor, points);
      const auto s = shapes->find (id);
      if (s != shapes->end ())
        collectPoints (vtkActor::SafeDownCast (s->second), points);
    }
  }
  if (points.empty ())
    return;
  vtkCamera* cam = ren->GetActiveCamera ();
  Eigen::Vector3d pos, focal, up;
  cam->GetPosition (pos.data ());
  cam->GetFocalPoint (focal.data ());
  cam->GetViewUp (up.data ());
  Eigen::Vector3d dir = focal - pos;
  if (!(dir.norm () > 0))
    return;
  dir.normalize ();
  const Eigen::Vector3d right = dir.cross (up).normalized ();
  if (!right.allFinite ())
    return;
  const Eigen::Vector3d true_up = right.cross (dir);
  // Half-angle tangents of the viewport, shrunk by the margin.
  const double aspect = std::max (ren->GetTiledAspectRatio (), 1e-3);
  double tan_v = std::tan (cam->GetViewAngle () * M_PI / 360.0), tan_h = tan_v * aspect;
  if (cam->GetUseHorizontalViewAngle ())
  {
    tan_h = tan_v;
    tan_v = tan_h / aspect;
  }
  tan_v *= 1.0 - margin;
  tan_h *= 1.0 - margin;
  // The subject's extent in the camera's axes; its centre becomes the focal point.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant (std::numeric_limits<double>::max ()), hi = -lo;
  for (const auto& p : points)
  {
    const Eigen::Vector3d q (p.dot (right), p.dot (true_up), p.dot (dir));
    lo = lo.cwiseMin (q);
    hi = hi.cwiseMax (q);
  }
  const Eigen::Vector3d c = (lo + hi) / 2;
  // Smallest distance from the centre that keeps every point inside the frustum.
  double distance = 0;
  for (const auto& p : points)
  {
    const Eigen::Vector3d q = Eigen::Vector3d (p.dot (right), p.dot (true_up), p.dot (dir)) - c;
    distance = std::max (distance, std::max (std::abs (q.x ()) / tan_h, std::abs (q.y ()) / tan_v) - q.z ());
  }
  const double extent = (hi - lo).norm ();
  distance = std::max (distance, 1e-3 * extent + 1e-9);
  const Eigen::Vector3d centre = c.x () * right + c.y () * true_up + c.z () * dir;
  const Eigen::Vector3d eye = centre - distance * dir;
  cam->SetFocalPoint (centre.data ());
  cam->SetPosition (eye.data ());
  cam->SetViewUp (true_up.data ());
  ren->ResetCameraClippingRange ();
}

void
saveScreenshot (pcl::visualization::PCLVisualizer& viewer, const std::string& png)
{
  vtkRenderWindow* win = viewer.getRenderWindow ();
  win->Render ();
  vtkNew<vtkWindowToImageFilter> grab;
  grab->SetInput (win);
  grab->ReadFrontBufferOff ();
  grab->Update ();
  vtkNew<vtkPNGWriter> writer;
  writer->SetFileName (png.c_str ());
  writer->SetInputConnection (grab->GetOutputPort ());
  writer->Write ();
  std::error_code ec;
  if (!std::filesystem::is_regular_file (png, ec) || std::filesystem::file_size (png, ec) == 0)
    throw std::runtime_error ("could not write " + png);
}

}  // namespace apps
}  // namespace pclx

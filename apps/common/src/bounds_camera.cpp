#include <pclx/apps/bounds_camera.h>

#include <vtkCamera.h>
#include <vtkMatrix4x4.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pclx {
namespace apps {

Eigen::Vector3f
boxCorner (const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, int i)
{
  return {i & 1 ? hi.x () : lo.x (), i & 2 ? hi.y () : lo.y (), i & 4 ? hi.z () : lo.z ()};
}

void
frameBounds (vtkCamera& cam, double aspect, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi,
             const Eigen::Vector3d& dir_in, const Eigen::Vector3d& up_in, double margin)
{
  const Eigen::Vector3d dir = -dir_in.normalized ();  // view direction: towards the data
  Eigen::Vector3d right = dir.cross (up_in);
  if (right.norm () < 1e-6)
    right = dir.unitOrthogonal ();
  right.normalize ();
  const Eigen::Vector3d up = right.cross (dir);
  const double tan_v = std::tan (cam.GetViewAngle () * M_PI / 360.0) * (1 - margin);
  const double tan_h = tan_v * aspect;
  const Eigen::Vector3d c = ((lo + hi) / 2).cast<double> ();
  double distance = 0;
  for (int i = 0; i < 8; ++i)
  {
    const Eigen::Vector3d q = boxCorner (lo, hi, i).cast<double> () - c;
    distance =
        std::max (distance, std::max (std::abs (q.dot (right)) / tan_h, std::abs (q.dot (up)) / tan_v) - q.dot (dir));
  }
  distance = std::max (distance, 1e-3 * (hi - lo).cast<double> ().norm () + 1e-9);
  const Eigen::Vector3d eye = c - distance * dir;
  cam.SetFocalPoint (c.data ());
  cam.SetPosition (eye.data ());
  cam.SetViewUp (up.data ());
}

void
clipToBounds (vtkCamera& cam, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi)
{
  double pos[3], dop[3];
  cam.GetPosition (pos);
  cam.GetDirectionOfProjection (dop);
  double near = std::numeric_limits<double>::max (), far = 0;
  for (int i = 0; i < 8; ++i)
  {
    const Eigen::Vector3d p = boxCorner (lo, hi, i).cast<double> ();
    const double d = (p - Eigen::Vector3d (pos[0], pos[1], pos[2])).dot (Eigen::Vector3d (dop[0], dop[1], dop[2]));
    near = std::min (near, d);
    far = std::max (far, d);
  }
  // A little room on both sides; the near plane kept off zero for the depth buffer's sake.
  far = std::max (far * 1.05, 1e-6);
  near = std::max (near * 0.95, far * 1e-4);
  cam.SetClippingRange (near, far);
}

void
orbitCamera (vtkCamera& cam, const Eigen::Vector3d& centre, const Eigen::Vector3d& start_eye,
             const Eigen::Vector3d& up, double t, double period)
{
  const Eigen::Vector3d eye =
      centre + Eigen::AngleAxisd (2 * M_PI * t / period, up.normalized ()) * (start_eye - centre);
  cam.SetFocalPoint (centre.data ());
  cam.SetPosition (eye.data ());
  cam.SetViewUp (up.data ());
  cam.OrthogonalizeViewUp ();
}

Eigen::Matrix4f
viewProjection (vtkCamera& cam, int width, int height)
{
  Eigen::Matrix4f vp;
  vtkMatrix4x4* m = cam.GetCompositeProjectionTransformMatrix (double (width) / height, -1, 1);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      vp (i, j) = static_cast<float> (m->GetElement (i, j));
  return vp;
}

}  // namespace apps
}  // namespace pclx

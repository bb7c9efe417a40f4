// potree_reference: renders a cloud with VTK from a given perspective camera (one pixel per
// point, white on black, off-screen) and prints the bounding box of the lit pixels as JSON.
// The browser check compares it with what potree-core draws of our Potree output from the
// same camera (check_potree_browser.py).
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <CLI/CLI.hpp>
#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPNGWriter.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkWindowToImageFilter.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace {

// The cloud's finite points as VTK vertices.
vtkNew<vtkPolyData>
toPolyData (const pcl::PointCloud<pcl::PointXYZ>& cloud)
{
  vtkNew<vtkPoints> points;
  vtkNew<vtkCellArray> vertices;
  for (const auto& p : cloud)
    if (std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z))
    {
      const vtkIdType id = points->InsertNextPoint (p.x, p.y, p.z);
      vertices->InsertNextCell (1, &id);
    }
  vtkNew<vtkPolyData> poly;
  poly->SetPoints (points);
  poly->SetVerts (vertices);
  return poly;
}

// Bounding box (x0, y0, x1, y1; y down, as in the browser) of the non-black pixels.
std::array<int, 4>
litBox (vtkImageData* image, long& lit)
{
  int dims[3];
  image->GetDimensions (dims);
  const int comps = image->GetNumberOfScalarComponents ();
  const auto* px = static_cast<const unsigned char*> (image->GetScalarPointer ());
  std::array<int, 4> box{dims[0], dims[1], -1, -1};
  lit = 0;
  for (int y = 0; y < dims[1]; ++y)
    for (int x = 0; x < dims[0]; ++x)
    {
      const unsigned char* p = px + comps * (static_cast<long> (y) * dims[0] + x);
      if (p[0] + p[1] + p[2] == 0)
        continue;
      ++lit;
      const int row = dims[1] - 1 - y;  // VTK's first row is the bottom one
      box = {std::min (box[0], x), std::min (box[1], row), std::max (box[2], x), std::max (box[3], row)};
    }
  return box;
}

}  // namespace

int
main (int argc, char** argv)
{
  std::string input, png;
  int width = 640, height = 480;
  double fov = 50, near = 0.1, far = 1000;
  std::vector<double> eye, at, up{0, 1, 0};
  CLI::App app ("potree_reference: VTK rendering of a cloud from a perspective camera; prints the lit pixels' box");
  app.add_option ("input", input, "PCD file")->required ();
  app.add_option ("--width", width)->capture_default_str ();
  app.add_option ("--height", height)->capture_default_str ();
  app.add_option ("--fov", fov, "vertical field of view, degrees")->capture_default_str ();
  app.add_option ("--near", near)->capture_default_str ();
  app.add_option ("--far", far)->capture_default_str ();
  app.add_option ("--eye", eye, "camera position x y z")->expected (3)->required ();
  app.add_option ("--at", at, "point looked at x y z")->expected (3)->required ();
  app.add_option ("--up", up, "up direction x y z")->expected (3)->capture_default_str ();
  app.add_option ("--png", png, "also save the picture");
  CLI11_PARSE (app, argc, argv);

  pcl::PointCloud<pcl::PointXYZ> cloud;
  if (pcl::io::loadPCDFile (input, cloud) < 0 || cloud.empty ())
  {
    std::fprintf (stderr, "potree_reference: cannot read a cloud from %s\n", input.c_str ());
    return 1;
  }
  vtkNew<vtkPolyDataMapper> mapper;
  mapper->SetInputData (toPolyData (cloud));
  vtkNew<vtkActor> actor;
  actor->SetMapper (mapper);
  actor->GetProperty ()->SetPointSize (1);
  actor->GetProperty ()->SetColor (1, 1, 1);
  actor->GetProperty ()->LightingOff ();
  vtkNew<vtkRenderer> renderer;
  renderer->AddActor (actor);
  renderer->SetBackground (0, 0, 0);
  vtkCamera* camera = renderer->GetActiveCamera ();
  camera->SetPosition (eye.data ());
  camera->SetFocalPoint (at.data ());
  camera->SetViewUp (up.data ());
  camera->SetViewAngle (fov);  // vertical, as three.js's PerspectiveCamera
  camera->SetClippingRange (near, far);
  vtkNew<vtkRenderWindow> window;
  window->SetOffScreenRendering (1);
  window->SetMultiSamples (0);
  window->SetSize (width, height);
  window->AddRenderer (renderer);
  window->Render ();
  vtkNew<vtkWindowToImageFilter> grab;
  grab->SetInput (window);
  grab->ReadFrontBufferOff ();
  grab->Update ();
  long lit = 0;
  const auto box = litBox (grab->GetOutput (), lit);
  if (!png.empty ())
  {
    vtkNew<vtkPNGWriter> writer;
    writer->SetFileName (png.c_str ());
    writer->SetInputConnection (grab->GetOutputPort ());
    writer->Write ();
  }
  std::printf ("{\"bbox\": [%d, %d, %d, %d], \"lit\": %ld, \"points\": %zu}\n", box[0], box[1], box[2], box[3], lit,
               cloud.size ());
  return 0;
}

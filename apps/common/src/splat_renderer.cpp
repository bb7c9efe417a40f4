#include <pclx/apps/splat_renderer.h>
#include <pclx/apps/bounds_camera.h>

#include <vtkFloatArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPointGaussianMapper.h>
#include <vtkPoints.h>
#include <vtkProperty.h>
#include <vtkUnsignedCharArray.h>

#include <limits>

namespace pclx {
namespace apps {

namespace {

// The height ramp: deep blue, teal, sand, white, in 256 steps.
void
fillHeightRamp (std::array<std::array<std::uint8_t, 3>, 256>& ramp)
{
  const Eigen::Vector3f stops[4] = {
      {0.18f, 0.30f, 0.75f}, {0.15f, 0.70f, 0.65f}, {0.92f, 0.80f, 0.45f}, {1.f, 0.97f, 0.92f}};
  for (int i = 0; i < 256; ++i)
  {
    const float t = 3.f * i / 255.f;
    const int k = std::min (2, int (t));
    const Eigen::Vector3f c = stops[k] + (t - k) * (stops[k + 1] - stops[k]);
    for (int j = 0; j < 3; ++j)
      ramp[i][j] = static_cast<std::uint8_t> (255.f * c[j]);
  }
}

// One colour per level from a multiplicative hash: distinct, never too dark.
void
fillLevelPalette (std::array<std::array<std::uint8_t, 3>, 22>& level)
{
  for (int l = 0; l < 22; ++l)
  {
    std::uint32_t h = std::uint32_t (l + 3) * 2654435761u;
    for (int j = 0; j < 3; ++j)
      level[l][j] = static_cast<std::uint8_t> (70 + (h >> (8 * j + 8)) % 186);
  }
}

}  // namespace

SplatColouring::SplatColouring (Mode mode, const Eigen::Vector3f& up, const Eigen::Vector3f& lo,
                                const Eigen::Vector3f& hi)
  : mode_ (mode), up_ (up.normalized ())
{
  float zlo = std::numeric_limits<float>::max (), zhi = -zlo;
  for (int i = 0; i < 8; ++i)
  {
    const float z = up_.dot (boxCorner (lo, hi, i));
    zlo = std::min (zlo, z);
    zhi = std::max (zhi, z);
  }
  z0_ = zlo;
  inv_dz_ = zhi > zlo ? 255.f / (zhi - zlo) : 0.f;
  fillHeightRamp (ramp_);
  fillLevelPalette (level_);
}

vtkSmartPointer<vtkPolyData>
makeSplatData ()
{
  vtkSmartPointer<vtkPolyData> data = vtkSmartPointer<vtkPolyData>::New ();
  vtkNew<vtkPoints> pts;
  pts->SetDataTypeToFloat ();
  data->SetPoints (pts);
  vtkNew<vtkUnsignedCharArray> rgb;
  rgb->SetNumberOfComponents (3);
  rgb->SetName ("rgb");
  data->GetPointData ()->SetScalars (rgb);
  vtkNew<vtkFloatArray> scale;
  scale->SetName ("scale");
  data->GetPointData ()->AddArray (scale);
  return data;
}

SplatArrays
resizeSplatData (vtkPolyData& data, std::size_t n)
{
  auto* xyz = vtkFloatArray::SafeDownCast (data.GetPoints ()->GetData ());
  auto* rgb = vtkUnsignedCharArray::SafeDownCast (data.GetPointData ()->GetScalars ());
  auto* scale = vtkFloatArray::SafeDownCast (data.GetPointData ()->GetArray ("scale"));
  xyz->SetNumberOfTuples (static_cast<vtkIdType> (n));
  rgb->SetNumberOfTuples (static_cast<vtkIdType> (n));
  scale->SetNumberOfTuples (static_cast<vtkIdType> (n));
  return {xyz->GetPointer (0), rgb->GetPointer (0), scale->GetPointer (0)};
}

void
markSplatDataModified (vtkPolyData& data)
{
  data.GetPoints ()->GetData ()->Modified ();
  data.GetPointData ()->GetScalars ()->Modified ();
  data.GetPointData ()->GetArray ("scale")->Modified ();
  data.GetPoints ()->Modified ();
  data.Modified ();
}

vtkSmartPointer<vtkActor>
makeSplatActor (vtkPolyData* data)
{
  vtkNew<vtkPointGaussianMapper> mapper;
  mapper->SetInputData (data);
  mapper->SetScaleArray ("scale");
  mapper->SetScaleFactor (1.0);
  mapper->EmissiveOff ();
  mapper->SetTriangleScale (1.0f);
  mapper->SetSplatShaderCode ("//VTK::Color::Impl\n"
                              "float dist2 = dot(offsetVCVSOutput.xy, offsetVCVSOutput.xy);\n"
                              "if (dist2 > 1.0) { discard; }\n"
                              "float rim = 1.0 - 0.3 * dist2;\n"
                              "ambientColor *= rim;\n"
                              "diffuseColor *= rim;\n");
  mapper->SetScalarModeToUsePointData ();
  mapper->SetColorModeToDirectScalars ();
  mapper->ScalarVisibilityOn ();
  vtkSmartPointer<vtkActor> actor = vtkSmartPointer<vtkActor>::New ();
  actor->SetMapper (mapper);
  actor->GetProperty ()->SetAmbient (0.35);
  actor->GetProperty ()->SetDiffuse (0.65);
  return actor;
}

SplatRenderer::SplatRenderer (vtkRenderer* renderer, bool per_node) : renderer_ (renderer), per_node_ (per_node)
{
  if (per_node_)
    return;
  data_ = makeSplatData ();
  actor_ = makeSplatActor (data_);
  if (renderer_)
    renderer_->AddActor (actor_);
}

void
SplatRenderer::addActor (Cached& e)
{
  e.actor = makeSplatActor (e.data);
  if (renderer_)
    renderer_->AddActor (e.actor);
}

// Hides what left the shown set; forgets actors unused for 64 generations.
void
SplatRenderer::hideAndDropUnused ()
{
  for (auto i = cache_.begin (); i != cache_.end ();)
  {
    if (i->second.generation != generation_)
      i->second.actor->SetVisibility (false);
    if (generation_ - i->second.generation > 64)
    {
      if (renderer_)
        renderer_->RemoveActor (i->second.actor);
      i = cache_.erase (i);
    }
    else
      ++i;
  }
}

}  // namespace apps
}  // namespace pclx

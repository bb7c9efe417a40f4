// The default scene: a room with boxes and spheres seen from a camera on a slow orbit,
// ray cast exactly (no noise, no randomness: frame i is always the same image).
#include "frame_source.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pclx {
namespace openni2_virtual {

namespace {

struct V3
{
  double x, y, z;
};
V3
operator+ (V3 a, V3 b)
{
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
V3
operator- (V3 a, V3 b)
{
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
V3
operator* (double s, V3 a)
{
  return {s * a.x, s * a.y, s * a.z};
}
double
dot (V3 a, V3 b)
{
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
V3
cross (V3 a, V3 b)
{
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
V3
normalized (V3 a)
{
  return (1.0 / std::sqrt (dot (a, a))) * a;
}

struct Box
{
  V3 lo, hi, colour;
};
struct Sphere
{
  V3 c;
  double r;
  V3 colour;
};

constexpr double kRoomHalf = 4.0;    // walls at x, z = +-4 m
constexpr double kRoomHeight = 2.6;  // no ceiling: rays above the walls return no data
constexpr double kOrbitRadius = 2.8;
constexpr double kOrbitHeight = 1.4;
constexpr int kOrbitFrames = 900;  // 30 s per turn at 30 fps
constexpr double kMinRange = 0.4, kMaxRange = 10.0;

const Box kBoxes[] = {{{-1.2, 0.0, -0.6}, {-0.4, 0.8, 0.2}, {0.85, 0.35, 0.25}},
                      {{0.5, 0.0, 0.6}, {1.1, 0.4, 1.2}, {0.25, 0.55, 0.85}}};
const Sphere kSpheres[] = {{{0.6, 0.5, -0.7}, 0.5, {0.3, 0.75, 0.35}}, {{-0.3, 0.25, 1.0}, 0.25, {0.9, 0.8, 0.2}}};

struct Hit
{
  double t = std::numeric_limits<double>::infinity ();
  V3 n{0, 0, 0};
  V3 colour{0, 0, 0};
};

// Slab test; keeps the entry face's normal.
void
hitBox (const Box& b, V3 o, V3 d, Hit& h)
{
  double t0 = 0, t1 = std::numeric_limits<double>::infinity ();
  int axis = -1;
  const double os[3] = {o.x, o.y, o.z}, ds[3] = {d.x, d.y, d.z};
  const double lo[3] = {b.lo.x, b.lo.y, b.lo.z}, hi[3] = {b.hi.x, b.hi.y, b.hi.z};
  double sign = 0;
  for (int a = 0; a < 3; ++a)
  {
    if (ds[a] == 0)
    {
      if (os[a] < lo[a] || os[a] > hi[a])
        return;
      continue;
    }
    double ta = (lo[a] - os[a]) / ds[a], tb = (hi[a] - os[a]) / ds[a];
    double s = -1;
    if (ta > tb)
    {
      std::swap (ta, tb);
      s = 1;
    }
    if (ta > t0)
    {
      t0 = ta;
      axis = a;
      sign = s;
    }
    t1 = std::min (t1, tb);
    if (t0 > t1)
      return;
  }
  if (axis < 0 || t0 >= h.t)
    return;
  h.t = t0;
  h.n = {axis == 0 ? sign : 0, axis == 1 ? sign : 0, axis == 2 ? sign : 0};
  h.colour = b.colour;
}

void
hitSphere (const Sphere& s, V3 o, V3 d, Hit& h)
{
  const V3 oc = o - s.c;
  const double a = dot (d, d), b = dot (oc, d), c = dot (oc, oc) - s.r * s.r;
  const double disc = b * b - a * c;
  if (disc < 0)
    return;
  const double t = (-b - std::sqrt (disc)) / a;
  if (t <= 0 || t >= h.t)
    return;
  h.t = t;
  h.n = normalized (o + t * d - s.c);
  h.colour = s.colour;
}

// The room seen from inside: floor (checkered) and four walls, whichever the ray leaves through.
void
hitRoom (V3 o, V3 d, Hit& h)
{
  auto consider = [&] (double t, V3 n, V3 colour) {
    if (t <= 0 || t >= h.t)
      return;
    const V3 p = o + t * d;
    if (p.y < -1e-9 || p.y > kRoomHeight || std::abs (p.x) > kRoomHalf + 1e-9 || std::abs (p.z) > kRoomHalf + 1e-9)
      return;
    h.t = t;
    h.n = n;
    h.colour = colour;
  };
  if (d.y < 0)
  {
    const double t = -o.y / d.y;
    const V3 p = o + t * d;
    const bool dark = (int (std::floor (p.x / 0.5)) + int (std::floor (p.z / 0.5))) & 1;
    consider (t, {0, 1, 0}, dark ? V3{0.45, 0.42, 0.4} : V3{0.75, 0.72, 0.68});
  }
  const V3 wall{0.8, 0.8, 0.78};
  if (d.x != 0)
    consider ((std::copysign (kRoomHalf, d.x) - o.x) / d.x, {-std::copysign (1.0, d.x), 0, 0}, wall);
  if (d.z != 0)
    consider ((std::copysign (kRoomHalf, d.z) - o.z) / d.z, {0, 0, -std::copysign (1.0, d.z)},
              V3{0.7, 0.75, 0.82});
}

class GeneratedSource : public FrameSource
{
public:
  GeneratedSource ()
  {
    // Kinect-like focal length; the principal point where PCL's OpenNI2Grabber assumes it
    // ((width - 1) / 2), so its point clouds are the rendered geometry exactly.
    cam_.width = 640;
    cam_.height = 480;
    cam_.fx = cam_.fy = 525.0;
    cam_.cx = 319.5;
    cam_.cy = 239.5;
  }

  const CameraModel&
  camera () const override
  {
    return cam_;
  }

  bool
  colourRegistered () const override
  {
    return true;
  }

  int
  maxDepth () const override
  {
    return int (kMaxRange * 1000);
  }

  std::string
  description () const override
  {
    return "generated scene (room, two boxes, two spheres, orbiting camera)";
  }

  bool
  render (std::uint64_t index, int width, int height, bool colour, Frame& out, std::string& error) override
  {
    if (width <= 0 || height <= 0 || cam_.width % width != 0 || cam_.width / width != cam_.height / height)
    {
      error = "unsupported output size " + std::to_string (width) + "x" + std::to_string (height);
      return false;
    }
    const double scale = double (width) / cam_.width;
    const double fx = cam_.fx * scale, fy = cam_.fy * scale, cx = (width - 1) / 2.0, cy = (height - 1) / 2.0;
    const double angle = 2.0 * M_PI * double (index % kOrbitFrames) / kOrbitFrames;
    const V3 eye{kOrbitRadius * std::cos (angle), kOrbitHeight, kOrbitRadius * std::sin (angle)};
    const V3 target{0, 0.4, 0};
    const V3 f = normalized (target - eye);
    const V3 r = normalized (cross (f, {0, 1, 0}));
    const V3 down = cross (f, r);  // image v grows downwards
    const V3 light = normalized (V3{0.3, 1.0, 0.2});

    out.width = width;
    out.height = height;
    out.depth.assign (std::size_t (width) * height, 0);
    out.rgb.assign (colour ? std::size_t (width) * height * 3 : 0, 0);
    for (int v = 0; v < height; ++v)
      for (int u = 0; u < width; ++u)
      {
        // Not normalised: its component along f is 1, so the hit parameter t is the depth z.
        const V3 d = f + ((u - cx) / fx) * r + ((v - cy) / fy) * down;
        Hit h;
        hitRoom (eye, d, h);
        for (const Box& b : kBoxes)
          hitBox (b, eye, d, h);
        for (const Sphere& s : kSpheres)
          hitSphere (s, eye, d, h);
        if (!(h.t >= kMinRange && h.t <= kMaxRange))
          continue;
        const std::size_t i = std::size_t (v) * width + u;
        out.depth[i] = std::uint16_t (std::lround (h.t * 1000.0));
        if (colour)
        {
          const double lambert = 0.35 + 0.65 * std::max (0.0, dot (h.n, light));
          out.rgb[3 * i] = std::uint8_t (std::lround (255.0 * std::min (1.0, lambert * h.colour.x)));
          out.rgb[3 * i + 1] = std::uint8_t (std::lround (255.0 * std::min (1.0, lambert * h.colour.y)));
          out.rgb[3 * i + 2] = std::uint8_t (std::lround (255.0 * std::min (1.0, lambert * h.colour.z)));
        }
      }
    return true;
  }

private:
  CameraModel cam_;
};

}  // namespace

std::unique_ptr<FrameSource>
makeGeneratedSource ()
{
  return std::make_unique<GeneratedSource> ();
}

}  // namespace openni2_virtual
}  // namespace pclx

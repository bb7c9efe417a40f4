#include <pclx/apps/cloud_loader.h>

#include <pcl/common/io.h>
#include <pcl/common/point_tests.h>
#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>

namespace pclx {
namespace apps {

namespace {

// PCL's readers print their own errors and, for the PLY camera element, a warning per
// property it does not store; the file was checked before and failures become one
// LoadError, so they stay quiet while they read.
class QuietPcl
{
public:
  QuietPcl () : level_ (pcl::console::getVerbosityLevel ()) { pcl::console::setVerbosityLevel (pcl::console::L_ALWAYS); }
  ~QuietPcl () { pcl::console::setVerbosityLevel (level_); }
  QuietPcl (const QuietPcl&) = delete;
  QuietPcl& operator= (const QuietPcl&) = delete;

private:
  pcl::console::VERBOSITY_LEVEL level_;
};

bool
isFloatable (const pcl::PCLPointField& f)
{
  static const char* names[] = {"x", "y", "z", "normal_x", "normal_y", "normal_z", "curvature", "intensity"};
  return f.count == 1 && f.datatype != pcl::PCLPointField::FLOAT32 &&
         std::any_of (std::begin (names), std::end (names), [&f] (const char* n) { return f.name == n; });
}

template <typename T>
double
readAs (const std::uint8_t* p)
{
  T v;
  std::memcpy (&v, p, sizeof v);
  return static_cast<double> (v);
}

double
readValue (const std::uint8_t* p, std::uint8_t type)
{
  switch (type)
  {
  case pcl::PCLPointField::INT8: return readAs<std::int8_t> (p);
  case pcl::PCLPointField::UINT8: return readAs<std::uint8_t> (p);
  case pcl::PCLPointField::INT16: return readAs<std::int16_t> (p);
  case pcl::PCLPointField::UINT16: return readAs<std::uint16_t> (p);
  case pcl::PCLPointField::INT32: return readAs<std::int32_t> (p);
  case pcl::PCLPointField::UINT32: return readAs<std::uint32_t> (p);
  case pcl::PCLPointField::INT64: return readAs<std::int64_t> (p);
  case pcl::PCLPointField::UINT64: return readAs<std::uint64_t> (p);
  case pcl::PCLPointField::FLOAT64: return readAs<double> (p);
  default: return std::numeric_limits<double>::quiet_NaN ();
  }
}

// Coordinates, normals, curvature and intensity stored as double or integers (e.g. a PLY
// with `property double x`) become float32, the type of PCL's point fields.
void
floatFields (pcl::PCLPointCloud2& blob)
{
  if (std::none_of (blob.fields.begin (), blob.fields.end (), isFloatable))
    return;
  std::vector<pcl::PCLPointField> fields = blob.fields;
  std::uint32_t offset = 0;
  for (auto& f : fields)
  {
    if (isFloatable (f))
      f.datatype = pcl::PCLPointField::FLOAT32;
    f.offset = offset;
    offset += static_cast<std::uint32_t> (pcl::getFieldSize (f.datatype)) * std::max<std::uint32_t> (f.count, 1);
  }
  const std::size_t n = std::size_t (blob.width) * blob.height;
  std::vector<std::uint8_t> data (n * offset);
  for (std::size_t i = 0; i < n; ++i)
  {
    const std::size_t row = i / blob.width, col = i % blob.width;
    const std::uint8_t* src = blob.data.data () + row * blob.row_step + col * blob.point_step;
    std::uint8_t* dst = data.data () + i * offset;
    for (std::size_t j = 0; j < fields.size (); ++j)
    {
      const auto& in = blob.fields[j];
      if (fields[j].datatype != in.datatype)
      {
        const float v = static_cast<float> (readValue (src + in.offset, in.datatype));
        std::memcpy (dst + fields[j].offset, &v, sizeof v);
      }
      else
        std::memcpy (dst + fields[j].offset, src + in.offset,
                     pcl::getFieldSize (in.datatype) * std::max<std::uint32_t> (in.count, 1));
    }
  }
  blob.fields = std::move (fields);
  blob.point_step = offset;
  blob.row_step = offset * blob.width;
  blob.data = std::move (data);
}

// Every field must lie inside the point and the data must hold every row.
void
checkLayout (const std::string& path, const pcl::PCLPointCloud2& blob)
{
  for (const auto& f : blob.fields)
  {
    const std::size_t size = pcl::getFieldSize (f.datatype);
    if (size == 0 || std::uint64_t (f.offset) + size * std::max<std::uint32_t> (f.count, 1) > blob.point_step)
      throw LoadError (path + ": field " + f.name + " lies outside the point");
  }
  if (std::uint64_t (blob.point_step) * blob.width > blob.row_step ||
      blob.data.size () < std::uint64_t (blob.row_step) * blob.height)
    throw LoadError (path + ": PCL read fewer bytes than the header declares");
}

[[noreturn]] void
xyzError (const std::string& path, std::size_t line, const std::string& what)
{
  throw LoadError (path + ":" + std::to_string (line) + ": " + what);
}

pcl::PCLPointCloud2::Ptr
readXyz (const std::string& path)
{
  std::ifstream in (path);
  if (!in)
    throw LoadError (path + ": cannot be read");
  std::vector<float> values;
  std::size_t columns = 0, line_no = 0;
  std::string line;
  while (std::getline (in, line))
  {
    ++line_no;
    const char* p = line.c_str ();
    while (*p == ' ' || *p == '\t' || *p == '\r')
      ++p;
    if (*p == '\0' || *p == '#')
      continue;
    std::size_t n = 0;
    while (*p != '\0')
    {
      char* end = nullptr;
      const float v = std::strtof (p, &end);
      if (end == p || (*end != '\0' && *end != ' ' && *end != '\t' && *end != ',' && *end != '\r'))
        xyzError (path, line_no, "'" + line.substr (static_cast<std::size_t> (p - line.c_str ()), 20) + "' is not a number");
      values.push_back (v);
      ++n;
      p = end;
      while (*p == ' ' || *p == '\t' || *p == ',' || *p == '\r')
        ++p;
    }
    if (n < 3)
      xyzError (path, line_no, "needs at least three numbers (x y z)");
    if (columns == 0)
      columns = n;
    else if (n != columns)
      xyzError (path, line_no, std::to_string (n) + " numbers where line 1 has " + std::to_string (columns));
  }
  if (in.bad ())
    throw LoadError (path + ": read error");
  if (values.empty ())
    throw LoadError (path + ": has no points");
  const std::size_t count = values.size () / columns;
  if (count > kMaxPoints)
    throw LoadError (path + ": too many points");
  // Six columns are x y z nx ny nz when every (nx, ny, nz) is a unit vector (or NaN).
  bool normals = columns == 6;
  for (std::size_t i = 0; normals && i < count; ++i)
  {
    const float* v = &values[i * columns + 3];
    const float len = std::sqrt (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    normals = std::isnan (len) || std::abs (len - 1.f) < 0.01f;
  }
  auto blob = std::make_shared<pcl::PCLPointCloud2> ();
  if (normals)
  {
    pcl::PointCloud<pcl::PointNormal> cloud (static_cast<std::uint32_t> (count), 1);
    for (std::size_t i = 0; i < count; ++i)
    {
      const float* v = &values[i * columns];
      cloud[i].getVector3fMap () = Eigen::Vector3f (v[0], v[1], v[2]);
      cloud[i].getNormalVector3fMap () = Eigen::Vector3f (v[3], v[4], v[5]);
    }
    pcl::toPCLPointCloud2 (cloud, *blob);
    // No curvature column in the file.
    blob->fields.erase (std::remove_if (blob->fields.begin (), blob->fields.end (),
                                        [] (const pcl::PCLPointField& f) { return f.name == "curvature"; }),
                        blob->fields.end ());
  }
  else
  {
    pcl::PointCloud<pcl::PointXYZ> cloud (static_cast<std::uint32_t> (count), 1);
    for (std::size_t i = 0; i < count; ++i)
      cloud[i].getVector3fMap () = Eigen::Vector3f (values[i * columns], values[i * columns + 1], values[i * columns + 2]);
    pcl::toPCLPointCloud2 (cloud, *blob);
  }
  return blob;
}

}  // namespace

CloudFields
CloudFields::of (const pcl::PCLPointCloud2& blob)
{
  CloudFields f;
  auto has = [&blob] (const char* name) {
    return std::any_of (blob.fields.begin (), blob.fields.end (), [name] (const pcl::PCLPointField& p) { return p.name == name; });
  };
  f.xyz = has ("x") && has ("y") && has ("z");
  f.alpha = has ("rgba");
  f.rgb = has ("rgb") || f.alpha;
  f.normals = has ("normal_x") && has ("normal_y") && has ("normal_z");
  f.intensity = has ("intensity");
  f.curvature = has ("curvature");
  return f;
}

std::string
CloudFields::str () const
{
  std::string s;
  auto add = [&s] (bool on, const char* name) {
    if (on)
      s += (s.empty () ? "" : " ") + std::string (name);
  };
  add (xyz, "xyz");
  add (rgb && !alpha, "rgb");
  add (alpha, "rgba");
  add (normals, "normals");
  add (intensity, "intensity");
  add (curvature, "curvature");
  return s.empty () ? "no known fields" : s;
}

std::string
CloudInfo::summary () const
{
  std::string s = path + ": " + std::to_string (points) + " points";
  if (organized ())
    s += " (" + std::to_string (width) + " x " + std::to_string (height) + ")";
  s += ", " + fields.str ();
  if (finite != points)
    s += ", " + std::to_string (finite) + " finite";
  return s;
}

pcl::PCLPointCloud2::Ptr
loadCloudBlob (const std::string& path, CloudInfo* info)
{
  const FileCheck check = checkCloudFile (path);
  pcl::PCLPointCloud2::Ptr blob;
  if (check.format == CloudFormat::XYZ)
    blob = readXyz (path);
  else
  {
    blob = std::make_shared<pcl::PCLPointCloud2> ();
    Eigen::Vector4f origin;
    Eigen::Quaternionf orientation;
    int rc;
    {
      QuietPcl quiet;
      if (check.format == CloudFormat::PCD)
      {
        int version;
        rc = pcl::PCDReader ().read (path, *blob, origin, orientation, version);
      }
      else
      {
        int version;
        rc = pcl::PLYReader ().read (path, *blob, origin, orientation, version);
      }
    }
    if (rc < 0)
      throw LoadError (path + ": PCL cannot read the " + check.encoding + " data (corrupt or truncated)");
    if (std::uint64_t (blob->width) * blob->height != check.points)
      throw LoadError (path + ": read " + std::to_string (std::uint64_t (blob->width) * blob->height) +
                       " points where the header declares " + std::to_string (check.points));
  }
  checkLayout (path, *blob);
  floatFields (*blob);
  CloudInfo local;
  CloudInfo& i = info ? *info : local;
  i.path = path;
  i.file = check;
  i.fields = CloudFields::of (*blob);
  if (!i.fields.xyz)
    throw LoadError (path + ": has no x, y, z fields");
  i.width = blob->width;
  i.height = blob->height;
  i.points = std::size_t (blob->width) * blob->height;
  const auto xyz = toCloud<pcl::PointXYZ> (*blob);
  i.finite = static_cast<std::size_t> (
      std::count_if (xyz->begin (), xyz->end (), [] (const pcl::PointXYZ& p) { return pcl::isFinite (p); }));
  return blob;
}

void
requireFinitePoints (const CloudInfo& info)
{
  if (info.finite == 0)
    throw LoadError (info.path + ": has no finite points (all " + std::to_string (info.points) + " are NaN or infinite)");
}

}  // namespace apps
}  // namespace pclx

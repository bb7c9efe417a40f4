// The app kit: loading valid PCD / PLY / XYZ files into the file's fields, one LoadError
// for each kind of bad file (before PCL's readers could crash on it), depth folders in the
// 7-Scenes layout, frame sources, and the inputs the loader fuzzer found.
#include <pclx/apps/cloud_loader.h>
#include <pclx/apps/depth_frames.h>
#include <pclx/apps/frame_source.h>
#include <pclx/apps/mesh_stats.h>
#include <pclx/apps/progress.h>

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

namespace fs = std::filesystem;
using namespace pclx::apps;

namespace {

class AppKit : public ::testing::Test
{
protected:
  void
  SetUp () override
  {
    dir_ = fs::temp_directory_path () /
           ("pclx_appkit_" + std::to_string (::getpid ()) + "_" +
            ::testing::UnitTest::GetInstance ()->current_test_info ()->name ());
    fs::remove_all (dir_);
    fs::create_directories (dir_);
  }
  void TearDown () override { fs::remove_all (dir_); }

  std::string path (const std::string& name) const { return (dir_ / name).string (); }

  std::string
  write (const std::string& name, const std::string& bytes) const
  {
    std::ofstream (path (name), std::ios::binary) << bytes;
    return path (name);
  }

  static std::string
  read (const std::string& p)
  {
    std::ifstream in (p, std::ios::binary);
    return std::string (std::istreambuf_iterator<char> (in), {});
  }

  static pcl::PointCloud<pcl::PointXYZRGBNormal>
  sample (std::size_t n = 50)
  {
    pcl::PointCloud<pcl::PointXYZRGBNormal> c;
    std::mt19937 rng (7);
    std::uniform_real_distribution<float> u (-1.f, 1.f);
    for (std::size_t i = 0; i < n; ++i)
    {
      pcl::PointXYZRGBNormal p;
      p.x = u (rng), p.y = u (rng), p.z = u (rng);
      p.r = static_cast<std::uint8_t> (i), p.g = 200, p.b = 7, p.a = 255;
      p.getNormalVector3fMap () = Eigen::Vector3f (u (rng), u (rng), u (rng)).normalized ();
      p.curvature = 0.f;
      c.push_back (p);
    }
    return c;
  }

  // The one-line message of the LoadError `fn` throws (empty if it threw none).
  template <typename F>
  static std::string
  errorOf (F fn)
  {
    try
    {
      fn ();
    }
    catch (const LoadError& e)
    {
      return e.what ();
    }
    return "";
  }

  static std::string
  loadError (const std::string& p)
  {
    return errorOf ([&p] { loadCloudBlob (p); });
  }

  fs::path dir_;
};

const char* kPcdHeader = "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";

// ---------------------------------------------------------------- valid files

TEST_F (AppKit, PcdAsciiKeepsEveryField)
{
  const auto src = sample ();
  ASSERT_EQ (pcl::io::savePCDFileASCII (path ("a.pcd"), src), 0);
  CloudInfo info;
  testing::internal::CaptureStderr ();
  const auto c = loadCloud<pcl::PointXYZRGBNormal> (path ("a.pcd"), &info);
  EXPECT_EQ (testing::internal::GetCapturedStderr (), "");
  EXPECT_TRUE (info.fields.xyz && info.fields.rgb && info.fields.normals && info.fields.curvature);
  EXPECT_FALSE (info.fields.intensity);
  EXPECT_EQ (info.file.encoding, "ascii");
  ASSERT_EQ (c->size (), src.size ());
  EXPECT_EQ (info.finite, src.size ());
  for (std::size_t i = 0; i < src.size (); ++i)
  {
    EXPECT_NEAR ((*c)[i].x, src[i].x, 1e-6f);
    EXPECT_EQ ((*c)[i].r, src[i].r);
    EXPECT_NEAR ((*c)[i].normal_z, src[i].normal_z, 1e-6f);
  }
}

TEST_F (AppKit, PcdBinaryAndCompressedXyzOnlyLoadQuietlyIntoRgba)
{
  pcl::PointCloud<pcl::PointXYZ> src;
  for (const auto& p : sample ())
    src.push_back (pcl::PointXYZ (p.x, p.y, p.z));
  ASSERT_EQ (pcl::io::savePCDFileBinary (path ("b.pcd"), src), 0);
  ASSERT_EQ (pcl::io::savePCDFileBinaryCompressed (path ("c.pcd"), src), 0);
  for (const char* name : {"b.pcd", "c.pcd"})
  {
    CloudInfo info;
    testing::internal::CaptureStderr ();
    const auto c = loadCloud<pcl::PointXYZRGBA> (path (name), &info);
    // No "Failed to find match for field 'rgba'".
    EXPECT_EQ (testing::internal::GetCapturedStderr (), "") << name;
    EXPECT_EQ (info.fields.str (), "xyz") << name;
    ASSERT_EQ (c->size (), src.size ());
    EXPECT_FLOAT_EQ ((*c)[9].y, src[9].y);
  }
  EXPECT_EQ (checkCloudFile (path ("c.pcd")).encoding, "binary_compressed");
}

TEST_F (AppKit, PlyAsciiAndBinaryWithAndWithoutCameraLoadQuietly)
{
  const auto src = sample ();
  pcl::PLYWriter w;
  for (bool binary : {false, true})
    for (bool camera : {false, true})
    {
      const std::string name = std::string (binary ? "bin" : "ascii") + (camera ? "_cam" : "") + ".ply";
      ASSERT_EQ (w.write (path (name), src, binary, camera), 0);
      EXPECT_EQ (read (path (name)).find ("element camera") != std::string::npos, camera);
      CloudInfo info;
      testing::internal::CaptureStderr ();
      const auto c = loadCloud<pcl::PointNormal> (path (name), &info);
      // No "property 'float32 focal' of element 'camera' is not handled".
      EXPECT_EQ (testing::internal::GetCapturedStderr (), "") << name;
      EXPECT_EQ (info.file.ply_camera, camera);
      EXPECT_TRUE (info.fields.xyz && info.fields.normals && info.fields.rgb) << info.fields.str ();
      ASSERT_EQ (c->size (), src.size ()) << name;
      EXPECT_NEAR ((*c)[3].normal_x, src[3].normal_x, 1e-5f);
      EXPECT_NEAR ((*c)[3].z, src[3].z, 1e-5f);
    }
}

TEST_F (AppKit, PlyDoubleCoordinatesBecomeFloats)
{
  write ("d.ply", "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\n"
                  "property double z\nend_header\n1.5 2 3\n4 5 6.25\n");
  const auto c = loadCloud<pcl::PointXYZ> (path ("d.ply"));
  ASSERT_EQ (c->size (), 2u);
  EXPECT_FLOAT_EQ ((*c)[0].x, 1.5f);
  EXPECT_FLOAT_EQ ((*c)[1].z, 6.25f);
}

TEST_F (AppKit, XyzTextWithAndWithoutNormals)
{
  write ("p.xyz", "# comment\n0 0 0\n1 2 3\n\n4 5 6\n");
  CloudInfo info;
  auto c = loadCloud<pcl::PointNormal> (path ("p.xyz"), &info);
  ASSERT_EQ (c->size (), 3u);
  EXPECT_EQ (info.fields.str (), "xyz");
  EXPECT_FLOAT_EQ ((*c)[2].y, 5.f);

  write ("n.xyz", "0 0 0 0 0 1\n1 0 0 1 0 0\n");
  c = loadCloud<pcl::PointNormal> (path ("n.xyz"), &info);
  EXPECT_EQ (info.fields.str (), "xyz normals");
  EXPECT_FLOAT_EQ ((*c)[1].normal_x, 1.f);

  // Six columns that are not unit normals (e.g. colours) stay xyz only.
  write ("rgb.xyz", "0 0 0 255 0 0\n1 0 0 0 255 0\n");
  loadCloudBlob (path ("rgb.xyz"), &info);
  EXPECT_EQ (info.fields.str (), "xyz");

  write ("bad.xyz", "0 0 0\n1 2 abc\n");
  EXPECT_NE (loadError (path ("bad.xyz")).find ("bad.xyz:2:"), std::string::npos);
  write ("short.xyz", "0 0 0\n1 2\n");
  EXPECT_NE (loadError (path ("short.xyz")).find ("three numbers"), std::string::npos);
}

// ---------------------------------------------------------------- bad files

TEST_F (AppKit, EmptyAndOneByteFiles)
{
  for (const char* name : {"e.pcd", "e.ply", "e.xyz"})
    EXPECT_NE (loadError (write (name, "")).find ("is empty"), std::string::npos) << name;
  // PCL 1.13's PCDReader segfaults on these.
  EXPECT_NE (loadError (write ("one.pcd", "#")), "");
  EXPECT_NE (loadError (write ("one.pcd", "\n")), "");
  EXPECT_NE (loadError (write ("one.ply", "p")), "");
  EXPECT_NE (loadError (write ("one.xyz", "1")), "");
}

TEST_F (AppKit, TruncatedBinaryFiles)
{
  pcl::PointCloud<pcl::PointXYZ> src;
  for (const auto& p : sample (100))
    src.push_back (pcl::PointXYZ (p.x, p.y, p.z));
  ASSERT_EQ (pcl::io::savePCDFileBinary (path ("full.pcd"), src), 0);
  ASSERT_EQ (pcl::io::savePCDFileBinaryCompressed (path ("fullc.pcd"), src), 0);
  ASSERT_EQ (pcl::PLYWriter ().write (path ("full.ply"), src, true, false), 0);
  for (const char* name : {"full.pcd", "fullc.pcd", "full.ply"})
  {
    const std::string bytes = read (path (name));
    const std::string cut = std::string ("cut_") + name;
    write (cut, bytes.substr (0, bytes.size () - 13));
    const std::string e = loadError (path (cut));
    EXPECT_NE (e.find ("truncated"), std::string::npos) << cut << ": " << e;
    EXPECT_EQ (e.find ('\n'), std::string::npos);
  }
}

TEST_F (AppKit, GarbageBytes)
{
  std::string junk;
  std::mt19937 rng (3);
  for (int i = 0; i < 4096; ++i)
    junk += static_cast<char> (rng () & 0xff);
  for (const char* name : {"g.pcd", "g.ply", "g.xyz"})
    EXPECT_NE (loadError (write (name, junk)), "") << name;
  EXPECT_NE (loadError (write ("magic.ply", "ply\n" + junk)), "");
}

TEST_F (AppKit, AbsurdAndInconsistentCounts)
{
  const std::string huge = loadError (write (
      "huge.pcd", std::string (kPcdHeader) + "WIDTH 4000000000\nHEIGHT 1\nPOINTS 4000000000\nDATA binary\n" +
                      std::string (120, '\0')));
  EXPECT_NE (huge.find ("absurd"), std::string::npos) << huge;
  const std::string big = loadError (write (
      "big.pcd", std::string (kPcdHeader) + "WIDTH 2000000000\nHEIGHT 1\nPOINTS 2000000000\nDATA ascii\n1 2 3\n"));
  EXPECT_NE (big.find ("cannot hold"), std::string::npos) << big;
  const std::string wh = loadError (
      write ("wh.pcd", std::string (kPcdHeader) + "WIDTH 3\nHEIGHT 2\nPOINTS 5\nDATA ascii\n" + std::string (60, '1')));
  EXPECT_NE (wh.find ("is not POINTS"), std::string::npos) << wh;
  const std::string ply = loadError (write (
      "huge.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
                  "property float y\nproperty float z\nend_header\n" + std::string (24, '\0')));
  EXPECT_NE (ply.find ("absurd"), std::string::npos) << ply;
  const std::string noz = loadError (write ("noz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                                       "property float y\nend_header\n1 2\n"));
  EXPECT_NE (noz.find ("no property z"), std::string::npos) << noz;
}

// Headers PCL would misread or abort on (found by the fuzzer).
TEST_F (AppKit, HeaderQuirksOfPclReadersAreRefused)
{
  // PCL reads on after DATA while lines look like header lines.
  const std::string e = loadError (write (
      "kw.pcd", std::string (kPcdHeader) + "WIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA binary\nCOLUMNS" + std::string (40, '\xff')));
  EXPECT_NE (e.find ("header keyword"), std::string::npos) << e;
  // A lone CR line ends PCL's PCD header early; it then segfaulted reading the data.
  const std::string cr = loadError (write ("cr.pcd", "\r\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                                                    "WIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA binary\n" + std::string (12, '\0')));
  EXPECT_NE (cr.find ("blank line"), std::string::npos) << cr;
  // PCL's PLY parser asserts (abort) on an obj_info line with leading white space.
  const std::string tab = loadError (write ("tab.ply", "ply\n\tobj_info x\nformat ascii 1.0\nelement vertex 1\n"
                                                       "property float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n"));
  EXPECT_NE (tab.find ("leading white space"), std::string::npos) << tab;
}

TEST_F (AppKit, UnknownExtensionDirectoryAndMissingFile)
{
  EXPECT_NE (loadError (write ("cloud.txt", "0 0 0\n")).find ("unknown file type"), std::string::npos);
  fs::create_directories (path ("folder.pcd"));
  EXPECT_NE (loadError (path ("folder.pcd")).find ("is a directory"), std::string::npos);
  EXPECT_NE (loadError (path ("missing.ply")).find ("no such file"), std::string::npos);
}

TEST_F (AppKit, NanOnlyCloudLoadsButHasNoFinitePoints)
{
  pcl::PointCloud<pcl::PointXYZ> src (4, 2);
  for (auto& p : src)
    p.x = p.y = p.z = std::numeric_limits<float>::quiet_NaN ();
  src.is_dense = false;
  ASSERT_EQ (pcl::io::savePCDFileBinary (path ("nan.pcd"), src), 0);
  CloudInfo info;
  const auto c = loadCloud<pcl::PointXYZ> (path ("nan.pcd"), &info);
  EXPECT_EQ (c->size (), 8u);
  EXPECT_TRUE (info.organized ());
  EXPECT_EQ (info.finite, 0u);
  EXPECT_NE (errorOf ([&info] { requireFinitePoints (info); }).find ("no finite points"), std::string::npos);
}

// Inputs the fuzzer (scripts/fuzz-loader.sh) found; each must be refused, not crash.
TEST_F (AppKit, FuzzerRegressionsAreRefused)
{
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator (PCLX_APPKIT_REGRESSIONS))
  {
    const std::string p = e.path ().string ();
    if (p.size () > 10 && p.compare (p.size () - 10, 10, ".depth.png") == 0)
      EXPECT_NE (errorOf ([&p] { readDepthPng (p); }), "") << p;
    else
      EXPECT_NE (loadError (p), "") << p;
    ++n;
  }
  EXPECT_GT (n, 0u);
}

// ---------------------------------------------------------------- depth frames

DepthImage16
ramp (int w, int h, std::uint16_t base)
{
  DepthImage16 img;
  img.width = w;
  img.height = h;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)
      img.mm.push_back (u == 0 ? 0 : static_cast<std::uint16_t> (base + 10 * u + v));
  return img;
}

TEST_F (AppKit, DepthFolderRoundTrip)
{
  const DepthIntrinsics k{100.f, 110.f, 3.5f, 2.5f};
  writeIntrinsics (path ("camera-intrinsics.txt"), k);
  writeDepthPng (path ("frame-000001.depth.png"), ramp (8, 6, 1000));
  writeDepthPng (path ("frame-000000.depth.png"), ramp (8, 6, 2000));
  Eigen::Matrix4f pose = Eigen::Matrix4f::Identity ();
  pose (0, 3) = 5.f;
  writePose (path ("frame-000000.pose.txt"), pose);
  DepthFrameFolder folder (dir_.string ());
  ASSERT_EQ (folder.size (), 2u);
  EXPECT_NE (folder.framePath (0).find ("frame-000000"), std::string::npos);
  const auto c = folder.load (0);
  ASSERT_EQ (c->width, 8u);
  ASSERT_EQ (c->height, 6u);
  EXPECT_TRUE (std::isnan ((*c) (0, 0).z));  // 0 = no depth
  const pcl::PointXYZ p = (*c) (5, 4);
  EXPECT_FLOAT_EQ (p.z, (2000 + 50 + 4) * 0.001f);
  EXPECT_NEAR (p.x, (5 - 3.5f) * p.z / 100.f, 1e-6f);
  EXPECT_NEAR (p.y, (4 - 2.5f) * p.z / 110.f, 1e-6f);
  Eigen::Matrix4f back;
  ASSERT_TRUE (folder.pose (0, back));
  EXPECT_FALSE (folder.pose (1, back));
  EXPECT_NEAR ((*folder.load (0, true)) (5, 4).x, p.x + 5.f, 1e-5f);
}

TEST_F (AppKit, DepthFolderErrors)
{
  EXPECT_NE (errorOf ([this] { DepthFrameFolder f (dir_.string ()); }).find ("no frame-"), std::string::npos);
  writeDepthPng (path ("frame-000000.depth.png"), ramp (4, 4, 1000));
  EXPECT_NE (errorOf ([this] { DepthFrameFolder f (dir_.string ()); }).find ("camera-intrinsics.txt"),
             std::string::npos);
  write ("camera-intrinsics.txt", "585 0 320\n0 585 240\n0 0\n");
  EXPECT_NE (errorOf ([this] { DepthFrameFolder f (dir_.string ()); }).find ("9 numbers"), std::string::npos);
  writeIntrinsics (path ("camera-intrinsics.txt"), DepthIntrinsics{585.f, 585.f, 320.f, 240.f});
  const std::string png = read (path ("frame-000000.depth.png"));
  write ("frame-000001.depth.png", png.substr (0, png.size () / 2));  // corrupt
  write ("frame-000002.depth.png", "not a png");
  DepthFrameFolder folder (dir_.string ());
  EXPECT_EQ (folder.load (0)->size (), 16u);
  EXPECT_NE (errorOf ([&folder] { folder.load (1); }), "");
  EXPECT_NE (errorOf ([&folder] { folder.load (2); }).find ("not a readable PNG"), std::string::npos);
}

// ---------------------------------------------------------------- frame sources

template <typename PointT>
std::size_t
drain (FrameSource<PointT>& src, std::vector<typename pcl::PointCloud<PointT>::ConstPtr>& frames, std::mutex& m)
{
  src.start ([&] (const typename pcl::PointCloud<PointT>::ConstPtr& c) {
    std::lock_guard<std::mutex> lock (m);
    frames.push_back (c);
  });
  // Until the source is done or check() throws (no time limit of our own).
  while (!src.finished ())
  {
    src.check ();
    std::this_thread::sleep_for (std::chrono::milliseconds (10));
  }
  src.stop ();
  return frames.size ();
}

TEST_F (AppKit, FileSourceDeliversOneFrame)
{
  ASSERT_EQ (pcl::io::savePCDFileBinary (path ("s.pcd"), sample ()), 0);
  SourceOptions o;
  o.input = path ("s.pcd");
  FrameSource<pcl::PointXYZRGBA> src (o);
  std::vector<pcl::PointCloud<pcl::PointXYZRGBA>::ConstPtr> frames;
  std::mutex m;
  EXPECT_EQ (drain (src, frames, m), 1u);
  EXPECT_EQ (frames[0]->size (), 50u);
  EXPECT_EQ (frames[0]->at (2).r, 2);
}

TEST_F (AppKit, DepthAndPcdFolderSourcesReplayEveryFrame)
{
  writeIntrinsics (path ("camera-intrinsics.txt"), DepthIntrinsics{50.f, 50.f, 3.5f, 2.5f});
  for (int i = 0; i < 3; ++i)
    writeDepthPng (path ("frame-00000" + std::to_string (i) + ".depth.png"), ramp (8, 6, 1000));
  SourceOptions o;
  o.depth_dir = dir_.string ();
  o.fps = 100;
  FrameSource<pcl::PointXYZRGBA> depth (o);
  std::vector<pcl::PointCloud<pcl::PointXYZRGBA>::ConstPtr> frames;
  std::mutex m;
  EXPECT_EQ (drain (depth, frames, m), 3u);
  EXPECT_EQ (frames[2]->height, 6u);

  fs::create_directories (path ("pcd"));
  pcl::PointCloud<pcl::PointXYZ> xyz;
  for (const auto& p : sample ())
    xyz.push_back (pcl::PointXYZ (p.x, p.y, p.z));
  for (int i = 0; i < 2; ++i)
    ASSERT_EQ (pcl::io::savePCDFileBinary (path ("pcd/f" + std::to_string (i) + ".pcd"), xyz), 0);
  o = SourceOptions ();
  o.pcd_dir = path ("pcd");
  o.fps = 50;
  FrameSource<pcl::PointXYZRGBA> pcd (o);
  frames.clear ();
  testing::internal::CaptureStderr ();
  EXPECT_EQ (drain (pcd, frames, m), 2u);
  EXPECT_EQ (testing::internal::GetCapturedStderr (), "");  // no field-match warnings
}

TEST_F (AppKit, BadSourcesAreRefusedBeforeStarting)
{
  fs::create_directories (path ("pcd"));
  write ("pcd/a.pcd", "");
  SourceOptions o;
  o.pcd_dir = path ("pcd");
  EXPECT_NE (errorOf ([&o] { FrameSource<pcl::PointXYZ> s (o); }).find ("is empty"), std::string::npos);
  o.fps = 0;
  EXPECT_THROW (FrameSource<pcl::PointXYZ> s (o), SourceError);
  o = SourceOptions ();
  o.pcd_dir = path ("none");
  EXPECT_THROW (FrameSource<pcl::PointXYZ> s (o), SourceError);
  o = SourceOptions ();
  EXPECT_THROW (FrameSource<pcl::PointXYZ> s (o), SourceError);
}

TEST_F (AppKit, DepthReplayWithCorruptFrameReportsIt)
{
  writeIntrinsics (path ("camera-intrinsics.txt"), DepthIntrinsics{50.f, 50.f, 3.5f, 2.5f});
  writeDepthPng (path ("frame-000000.depth.png"), ramp (8, 6, 1000));
  write ("frame-000001.depth.png", "\x89PNG broken");
  SourceOptions o;
  o.depth_dir = dir_.string ();
  o.fps = 100;
  FrameSource<pcl::PointXYZ> src (o);
  std::vector<pcl::PointCloud<pcl::PointXYZ>::ConstPtr> frames;
  std::mutex m;
  std::string error;
  try
  {
    drain (src, frames, m);
  }
  catch (const SourceError& e)
  {
    error = e.what ();
  }
  EXPECT_NE (error.find ("frame-000001.depth.png"), std::string::npos) << error;
  EXPECT_EQ (frames.size (), 1u);
}

// ---------------------------------------------------------------- progress

TEST_F (AppKit, ProgressIsQuietForShortStagesAndClosesLongOnes)
{
  std::FILE* f = std::tmpfile ();
  {
    Progress quick ("quick", 10, 1000.0, f);
    quick.update (5);
  }
  {
    Progress slow ("slow", 0, 0.0, f);  // delay 0: every stage counts as long
  }
  std::rewind (f);
  char buf[256] = {};
  const std::size_t n = std::fread (buf, 1, sizeof buf - 1, f);
  std::fclose (f);
  const std::string out (buf, n);
  EXPECT_EQ (out.find ("quick"), std::string::npos) << out;
  EXPECT_NE (out.find ("slow: done in"), std::string::npos) << out;
}

}  // namespace

TEST (MeshStats, OpenAndNonManifoldEdges)
{
  auto tri = [] (pcl::index_t a, pcl::index_t b, pcl::index_t c) {
    pcl::Vertices v;
    v.vertices = {a, b, c};
    return v;
  };
  pcl::PolygonMesh mesh;
  std::size_t boundary = 9, non_manifold = 9;
  pclx::apps::countOpenEdges (mesh, boundary, non_manifold);
  EXPECT_EQ (boundary, 0u);
  EXPECT_EQ (non_manifold, 0u);
  // A closed tetrahedron: every edge used twice.
  mesh.polygons = {tri (0, 1, 2), tri (0, 3, 1), tri (1, 3, 2), tri (2, 3, 0)};
  pclx::apps::countOpenEdges (mesh, boundary, non_manifold);
  EXPECT_EQ (boundary, 0u);
  EXPECT_EQ (non_manifold, 0u);
  // One face gone: its three edges are used once.
  mesh.polygons.pop_back ();
  pclx::apps::countOpenEdges (mesh, boundary, non_manifold);
  EXPECT_EQ (boundary, 3u);
  EXPECT_EQ (non_manifold, 0u);
  // Three faces on edge (0, 1) of the open tetrahedron: non-manifold.
  mesh.polygons.push_back (tri (1, 0, 4));
  pclx::apps::countOpenEdges (mesh, boundary, non_manifold);
  EXPECT_EQ (non_manifold, 1u);
  EXPECT_EQ (boundary, 5u);
}

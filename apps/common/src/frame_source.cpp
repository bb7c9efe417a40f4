#include <pclx/apps/cloud_loader.h>
#include <pclx/apps/depth_frames.h>
#include <pclx/apps/frame_source.h>

#include <pcl/common/io.h>
#include <pcl/io/image_grabber.h>
#include <pcl/io/openni2_grabber.h>
#include <pcl/io/pcd_grabber.h>
#include <pcl/point_types.h>

#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <sstream>
#include <thread>

namespace pclx {
namespace apps {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

void
addSourceOptions (CLI::App& app, SourceOptions& o)
{
  auto* src = app.add_option_group ("source", "where the points come from (one of)");
  src->add_option ("input,-i,--input", o.input, "a .pcd, .ply or .xyz file");
  src->add_option ("--pcd-dir", o.pcd_dir, "recorded frames: a folder of .pcd files, replayed by pcl::PCDGrabber");
  src->add_option ("--image-dir", o.image_dir, "recorded frames for pcl::ImageGrabber (TIFF, or PCLZF with --pclzf)");
  src->add_option ("--depth-dir", o.depth_dir,
                   "recorded frames in the 7-Scenes layout (frame-NNNNNN.depth.png, camera-intrinsics.txt)");
  src->add_option ("--device", o.device,
                   "live OpenNI2 device: \"\" (first), \"#N\", a URI or an .oni file (pcl::io::OpenNI2Grabber)");
  src->require_option (1);
  app.add_flag ("--pclzf", o.pclzf, "--image-dir holds PCLZF frames");
  app.add_option ("--fps", o.fps, "replay rate of recorded frames (> 0)")->capture_default_str ();
}

void
finishSourceOptions (const CLI::App& app, SourceOptions& o)
{
  o.has_device = app.count ("--device") > 0;
}

template <typename PointT>
struct FrameSource<PointT>::Impl
{
  SourceOptions opt;
  std::string description;
  Callback callback;
  std::size_t expected = 0;
  bool is_live = false;
  std::atomic<std::size_t> delivered{0};
  std::atomic<Clock::rep> last_frame{0};
  std::atomic<bool> stopping{false};
  Clock::time_point started;
  mutable std::mutex error_mutex;
  std::string error;  // a replay that failed on its way (depth frames)

  typename Cloud::ConstPtr file_cloud;
  std::unique_ptr<pcl::Grabber> grabber;
  std::function<void ()> connect;  // registers the grabber callback
  std::unique_ptr<DepthFrameFolder> depth;
  std::thread worker;

  void
  deliver (const typename Cloud::ConstPtr& cloud)
  {
    last_frame = Clock::now ().time_since_epoch ().count ();
    ++delivered;
    if (callback && !stopping)
      callback (cloud);
  }

  // Frames of type G reach the callback as PointT (present fields copied).
  template <typename G>
  void
  deliverAs (const typename pcl::PointCloud<G>::ConstPtr& cloud)
  {
    if constexpr (std::is_same_v<G, PointT>)
      deliver (cloud);
    else
    {
      typename Cloud::Ptr out (new Cloud);
      pcl::copyPointCloud (*cloud, *out);
      deliver (out);
    }
  }

  template <typename G>
  void
  connectGrabber ()
  {
    connect = [this] {
      std::function<void (const typename pcl::PointCloud<G>::ConstPtr&)> cb =
          [this] (const typename pcl::PointCloud<G>::ConstPtr& c) { deliverAs<G> (c); };
      grabber->registerCallback (cb);
    };
  }

  // PCDGrabber in the point type of the files, so PCL converts without missing fields.
  void
  openPcdDir ()
  {
    std::error_code ec;
    if (!fs::is_directory (opt.pcd_dir, ec))
      throw SourceError (opt.pcd_dir + ": not a folder");
    std::vector<std::string> files;
    for (const auto& e : fs::directory_iterator (opt.pcd_dir, ec))
      if (e.path ().extension () == ".pcd")
        files.push_back (e.path ().string ());
    std::sort (files.begin (), files.end ());
    if (files.empty ())
      throw SourceError ("no .pcd files in " + opt.pcd_dir);
    // PCDGrabber reads with PCDReader, which crashes on empty or truncated files.
    std::vector<std::string> fields;
    for (const auto& f : files)
    {
      const FileCheck c = checkCloudFile (f);
      if (&f != &files.front () && c.fields != fields)
        throw SourceError (f + ": its fields differ from the first frame's");
      fields = c.fields;
    }
    auto has = [&fields] (const char* n) { return std::find (fields.begin (), fields.end (), n) != fields.end (); };
    const bool rgb = has ("rgb") || has ("rgba"), normals = has ("normal_x");
    const float fps = opt.fps;
    auto make = [&] (auto tag) {
      using G = decltype (tag);
      grabber = std::make_unique<pcl::PCDGrabber<G>> (files, fps, false);
      connectGrabber<G> ();
    };
    if (rgb && normals)
      make (pcl::PointXYZRGBNormal ());
    else if (normals)
      make (pcl::PointNormal ());
    else if (rgb)
      make (pcl::PointXYZRGBA ());
    else if (has ("intensity"))
      make (pcl::PointXYZI ());
    else
      make (pcl::PointXYZ ());
    expected = files.size ();
    description = opt.pcd_dir + ": " + std::to_string (files.size ()) + " PCD frames";
  }

  void
  openDevice ()
  {
    try
    {
      auto g = std::make_unique<pcl::io::OpenNI2Grabber> (opt.device);
      grabber = std::move (g);
    }
    catch (const std::exception& e)
    {
      throw SourceError ("cannot open OpenNI2 device '" + opt.device + "': " + e.what ());
    }
    if (grabber->providesCallback<void (const typename Cloud::ConstPtr&)> ())
      connectGrabber<PointT> ();
    else
      connectGrabber<pcl::PointXYZ> ();  // depth only (no colour stream)
    is_live = true;
    description = "OpenNI2 device " + (opt.device.empty () ? std::string ("(first)") : opt.device);
  }

  void
  replayDepth ()
  {
    const auto period = std::chrono::duration<double> (1.0 / opt.fps);
    for (std::size_t i = 0; i < depth->size () && !stopping; ++i)
    {
      const auto t0 = Clock::now ();
      try
      {
        // The camera-to-world pose, when the folder has one, as the frame's sensor pose (PCD's
        // VIEWPOINT), the way recorded PCD frames carry it.
        const auto frame = depth->load (i);
        Eigen::Matrix4f pose;
        if (depth->pose (i, pose))
        {
          frame->sensor_origin_ = pose.col (3);
          frame->sensor_orientation_ = Eigen::Quaternionf (Eigen::Matrix3f (pose.topLeftCorner<3, 3> ()));
        }
        deliverAs<pcl::PointXYZ> (frame);
      }
      catch (const std::exception& e)
      {
        std::lock_guard<std::mutex> lock (error_mutex);
        error = e.what ();
        return;
      }
      std::this_thread::sleep_until (t0 + std::chrono::duration_cast<Clock::duration> (period));
    }
  }
};

template <typename PointT>
FrameSource<PointT>::FrameSource (const SourceOptions& options) : impl_ (new Impl)
{
  Impl& d = *impl_;
  d.opt = options;
  const bool recorded = !options.pcd_dir.empty () || !options.image_dir.empty () || !options.depth_dir.empty ();
  if (recorded && !(options.fps > 0))
    throw SourceError ("--fps must be > 0 for recorded frames");
  if (!options.input.empty ())
  {
    CloudInfo info;
    d.file_cloud = loadCloud<PointT> (options.input, &info);
    requireFinitePoints (info);
    d.expected = 1;
    d.description = info.summary ();
  }
  else if (!options.pcd_dir.empty ())
    d.openPcdDir ();
  else if (!options.image_dir.empty ())
  {
    std::error_code ec;
    if (!fs::is_directory (options.image_dir, ec))
      throw SourceError (options.image_dir + ": not a folder");
    try
    {
      d.grabber = std::make_unique<pcl::ImageGrabber<PointT>> (options.image_dir, options.fps, false, options.pclzf);
    }
    catch (const std::exception& e)
    {
      throw SourceError (options.image_dir + ": " + e.what ());
    }
    d.expected = static_cast<pcl::ImageGrabber<PointT>*> (d.grabber.get ())->size ();
    if (d.expected == 0)
      throw SourceError ("no frames in " + options.image_dir);
    d.template connectGrabber<PointT> ();
    d.description = options.image_dir + ": " + std::to_string (d.expected) + " image frames";
  }
  else if (!options.depth_dir.empty ())
  {
    d.depth = std::make_unique<DepthFrameFolder> (options.depth_dir);
    d.expected = d.depth->size ();
    d.description = options.depth_dir + ": " + std::to_string (d.expected) + " depth frames";
  }
  else if (options.has_device)
    d.openDevice ();
  else
    throw SourceError ("no input: give --input, --pcd-dir, --image-dir, --depth-dir or --device (see --help)");
}

template <typename PointT>
FrameSource<PointT>::~FrameSource ()
{
  stop ();
  // OpenNI2 2.2 can leave a stream's callback thread waiting for a frame that never comes
  // after stop () (its two auto-reset frame events drift apart when a frame arrives between
  // the callback's wake-up and its read). Destroying the device then cancels that thread after
  // 2 s and the unwind double-frees inside libOpenNI2 (seen with a loaded CPU: 3 of 8 runs).
  // A stopped OpenNI2 grabber is therefore not destroyed: the process is ending or moving on,
  // and the device's memory is what it would have freed.
  if (impl_->is_live && impl_->grabber)
    impl_->grabber.release ();
}

template <typename PointT>
void
FrameSource<PointT>::start (Callback callback)
{
  Impl& d = *impl_;
  d.callback = std::move (callback);
  d.started = Clock::now ();
  d.last_frame = d.started.time_since_epoch ().count ();
  if (d.file_cloud)
    d.deliver (d.file_cloud);
  else if (d.depth)
    d.worker = std::thread ([&d] { d.replayDepth (); });
  else if (d.grabber)
  {
    d.connect ();
    // PCL's OpenNI2Grabber asks every device for depth/colour frame sync and prints the refusal
    // to std::cerr. The pclx virtual camera refuses it on purpose (OpenNI2's synced frame holder
    // races at stop; drivers/openni2_virtual/README.md), so that one message is dropped for it;
    // everything else PCL prints passes through.
    std::ostringstream captured;
    std::streambuf* const cerr_buf = d.is_live ? std::cerr.rdbuf (captured.rdbuf ()) : nullptr;
    std::string failure;
    try
    {
      d.grabber->start ();
    }
    catch (const std::exception& e)
    {
      failure = e.what ();
    }
    if (cerr_buf)
    {
      std::cerr.rdbuf (cerr_buf);
      std::string text = captured.str ();
      const auto* ni = static_cast<pcl::io::OpenNI2Grabber*> (d.grabber.get ());
      const bool virtual_camera = ni->getDevice () && ni->getDevice ()->getUri ().rfind ("pclx://", 0) == 0;
      if (virtual_camera)
      {
        // The exception text is one line (function @ file @ line : message), then OpenNI's
        // empty extended error and blank lines.
        std::istringstream lines (text);
        std::string line, kept;
        bool dropping = false;
        while (std::getline (lines, line))
        {
          if (line.find ("Enabling depth color synchronization failed") != std::string::npos)
            dropping = true;
          else if (!(dropping && line.empty ()))
          {
            dropping = false;
            kept += line + "\n";
          }
        }
        text = kept;
      }
      std::cerr << text;
    }
    if (!failure.empty ())
      throw SourceError (d.description + ": cannot start: " + failure);
  }
}

template <typename PointT>
void
FrameSource<PointT>::stop ()
{
  Impl& d = *impl_;
  d.stopping = true;
  if (d.worker.joinable ())
    d.worker.join ();
  if (d.grabber && d.grabber->isRunning ())
    d.grabber->stop ();
}

template <typename PointT>
bool
FrameSource<PointT>::live () const
{
  return impl_->is_live;
}

template <typename PointT>
std::size_t
FrameSource<PointT>::expected () const
{
  return impl_->expected;
}

template <typename PointT>
std::size_t
FrameSource<PointT>::delivered () const
{
  return impl_->delivered;
}

template <typename PointT>
bool
FrameSource<PointT>::finished () const
{
  return !impl_->is_live && impl_->delivered >= impl_->expected;
}

template <typename PointT>
void
FrameSource<PointT>::check () const
{
  const Impl& d = *impl_;
  {
    std::lock_guard<std::mutex> lock (d.error_mutex);
    if (!d.error.empty ())
      throw SourceError (d.error);
  }
  if (finished ())
    return;
  const double silent =
      std::chrono::duration<double> (Clock::now () - Clock::time_point (Clock::duration (d.last_frame.load ()))).count ();
  // A replay waits 1/fps between frames; allow that on top.
  const double limit = d.opt.stall_seconds + (d.is_live ? 0.0 : 1.0 / d.opt.fps);
  if (silent <= limit)
    return;
  const std::string secs = std::to_string (static_cast<int> (silent)) + " s";
  if (d.is_live)
    throw SourceError (d.description + ": device stopped delivering frames (none for " + secs + ", " +
                       std::to_string (d.delivered.load ()) + " received)");
  throw SourceError (d.description + ": the replay stopped after " + std::to_string (d.delivered.load ()) + " of " +
                     std::to_string (d.expected) + " frames");
}

template <typename PointT>
const std::string&
FrameSource<PointT>::description () const
{
  return impl_->description;
}

template class FrameSource<pcl::PointXYZ>;
template class FrameSource<pcl::PointXYZRGB>;
template class FrameSource<pcl::PointXYZRGBA>;

}  // namespace apps
}  // namespace pclx

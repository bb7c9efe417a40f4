#pragma once
// One frame source for every app: a file (--input), recorded frames (--pcd-dir through
// pcl::PCDGrabber, --image-dir through pcl::ImageGrabber, --depth-dir: 7-Scenes depth PNGs)
// or a live OpenNI2 device (--device). Frames reach one callback as
// pcl::PointCloud<PointT>::ConstPtr, whatever fields the source has (only the present ones
// are copied, without PCL's field-match warnings).
#include <pcl/point_cloud.h>

#include <functional>
#include <memory>
#include <stdexcept>
#include <string>

namespace CLI {
class App;
}

namespace pclx {
namespace apps {

struct SourceOptions
{
  std::string input, pcd_dir, image_dir, depth_dir, device;
  bool has_device = false;  // --device was given ("" means the first device)
  bool pclzf = false;       // --image-dir holds PCLZF frames
  float fps = 10.f;         // replay rate of recorded frames (PCL's grabbers need > 0)
  double stall_seconds = 5; // a device silent this long has stopped
};

// Adds --input, --pcd-dir, --image-dir, --depth-dir, --device (one of them required),
// --pclzf and --fps. Call finishSourceOptions after parsing.
void addSourceOptions (CLI::App& app, SourceOptions& options);
void finishSourceOptions (const CLI::App& app, SourceOptions& options);

// Thrown for sources that cannot start and devices that stop delivering frames.
class SourceError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

template <typename PointT>
class FrameSource
{
public:
  using Cloud = pcl::PointCloud<PointT>;
  using Callback = std::function<void (const typename Cloud::ConstPtr&)>;

  // Checks the source (files are validated before any PCL reader sees them); throws
  // LoadError or SourceError.
  explicit FrameSource (const SourceOptions& options);
  ~FrameSource ();
  FrameSource (const FrameSource&) = delete;
  FrameSource& operator= (const FrameSource&) = delete;

  // Frames go to `callback`, from the grabber's thread (a file: at once, in this thread).
  void start (Callback callback);
  void stop ();

  bool live () const;             // a device: frames until stop()
  std::size_t expected () const;  // recorded frames in the source (0: live)
  std::size_t delivered () const;
  // Recorded sources: every frame delivered, or the replay ended early (then check()
  // throws). Live sources: never.
  bool finished () const;
  // Throws SourceError("device stopped delivering frames ...") when a live device has been
  // silent for stall_seconds, or a replay ended before all its frames.
  void check () const;
  const std::string& description () const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace apps
}  // namespace pclx

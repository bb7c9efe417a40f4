// OpenNI2 driver presenting a virtual depth camera (URI pclx://virtual): depth DEPTH_1_MM and
// colour RGB888 at 640x480 / 320x240, 30 fps, from a recorded folder or a generated scene.
// One frame thread per device paces both streams, so depth and colour share frame indices
// and timestamps (without OpenNI's frame sync, which is refused: see enableFrameSync).
#include "frame_source.h"

#include <Driver/OniDriverAPI.h>
#include <PS1080.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <thread>
#include <vector>

// ONI_EXPORT_DRIVER expects OpenNI's internal allocation macros (XnLib.h is not installed).
#define XN_NEW(type, arg) new (std::nothrow) type (arg)
#define XN_DELETE(p) delete (p)

namespace pclx {
namespace openni2_virtual {

namespace {

constexpr const char* kUri = "pclx://virtual";
constexpr const char* kMask = "pclxVirtual";
constexpr int kFps = 30;
// Kinect v1 projector-to-depth-camera distance, so disparity users get familiar numbers.
constexpr double kBaselineCm = 7.5;
constexpr std::uint64_t kZeroPlaneDistanceMm = 120;

using Clock = std::chrono::steady_clock;

// XnLogSeverity values (XnLog.h is not installed).
enum Severity
{
  kLogVerbose = 0,
  kLogInfo = 1,
  kLogWarning = 2,
  kLogError = 3
};

int
bytesPerPixel (OniPixelFormat f)
{
  return f == ONI_PIXEL_FORMAT_RGB888 ? 3 : 2;
}

template <typename T>
OniStatus
readValue (void* data, int* size, const T& value)
{
  if (*size != int (sizeof (T)))
    return ONI_STATUS_BAD_PARAMETER;
  std::memcpy (data, &value, sizeof (T));
  return ONI_STATUS_OK;
}

OniStatus
readString (void* data, int* size, const std::string& value)
{
  if (*size < int (value.size ()) + 1)
    return ONI_STATUS_BAD_PARAMETER;
  std::memcpy (data, value.c_str (), value.size () + 1);
  *size = int (value.size ()) + 1;
  return ONI_STATUS_OK;
}

}  // namespace

class VirtualDriver;
class VirtualDevice;

class VirtualStream : public oni::driver::StreamBase
{
public:
  VirtualStream (VirtualDevice& device, OniSensorType type, const OniVideoMode& mode)
    : device_ (device), type_ (type), mode_ (mode)
  {}
  ~VirtualStream () override;

  OniStatus
  start () override;
  void
  stop () override;

  OniStatus
  getProperty (int id, void* data, int* size) override;
  OniStatus
  setProperty (int id, const void* data, int size) override;
  OniBool
  isPropertySupported (int id) override;

  int
  getRequiredFrameSize () override
  {
    std::lock_guard<std::mutex> lock (mutex_);
    return mode_.resolutionX * mode_.resolutionY * bytesPerPixel (mode_.pixelFormat);
  }

  OniSensorType
  type () const
  {
    return type_;
  }

  OniVideoMode
  mode () const
  {
    std::lock_guard<std::mutex> lock (mutex_);
    return mode_;
  }

  // Called from the device's frame thread only.
  void
  deliver (const Frame& frame, int index, std::uint64_t timestamp_us);

private:
  VirtualDevice& device_;
  const OniSensorType type_;
  mutable std::mutex mutex_;
  OniVideoMode mode_;
  bool mirror_ = false;
  bool started_ = false;
};

class VirtualDevice : public oni::driver::DeviceBase
{
public:
  VirtualDevice (VirtualDriver& driver, std::unique_ptr<FrameSource> source);
  ~VirtualDevice () override;

  OniStatus
  getSensorInfoList (OniSensorInfo** sensors, int* count) override
  {
    *sensors = sensors_;
    *count = 2;
    return ONI_STATUS_OK;
  }

  oni::driver::StreamBase*
  createStream (OniSensorType type) override;
  void
  destroyStream (oni::driver::StreamBase* stream) override;

  OniStatus
  getProperty (int id, void* data, int* size) override;
  OniStatus
  setProperty (int id, const void* data, int size) override;
  OniBool
  isPropertySupported (int id) override;
  OniBool
  isImageRegistrationModeSupported (OniImageRegistrationMode mode) override
  {
    return mode == ONI_IMAGE_REGISTRATION_OFF ||
           (mode == ONI_IMAGE_REGISTRATION_DEPTH_TO_COLOR && source_->colourRegistered ());
  }

  const FrameSource&
  source () const
  {
    return *source_;
  }

  bool
  supports (OniSensorType type, const OniVideoMode& mode) const;

  OniStatus
  startStream (VirtualStream* stream);
  void
  stopStream (VirtualStream* stream);

  // Stops the frame thread for good (with the streams it served).
  void
  destroyAllStreams ();

  bool
  failed () const
  {
    std::lock_guard<std::mutex> lock (mutex_);
    return failed_;
  }

  void
  log (int severity, const char* format, ...);

private:
  void
  run (int generation);

  VirtualDriver& driver_;
  std::unique_ptr<FrameSource> source_;
  std::vector<OniVideoMode> modes_[2];
  OniSensorInfo sensors_[2];
  OniImageRegistrationMode registration_ = ONI_IMAGE_REGISTRATION_OFF;

  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::vector<VirtualStream*> streams_;  // created
  std::vector<VirtualStream*> active_;   // started
  std::thread thread_;
  int generation_ = 0;  // bumped to retire the running frame thread
  bool delivering_ = false;
  bool failed_ = false;
  int next_index_ = 1;  // OpenNI frame indices start at 1
  const Clock::time_point epoch_ = Clock::now ();
};

class VirtualDriver : public oni::driver::DriverBase
{
public:
  explicit VirtualDriver (OniDriverServices* services) : DriverBase (services)
  {
    std::memset (&info_, 0, sizeof (info_));
    std::snprintf (info_.uri, sizeof (info_.uri), "%s", kUri);
    std::snprintf (info_.vendor, sizeof (info_.vendor), "pclx");
    std::snprintf (info_.name, sizeof (info_.name), "Virtual depth camera");
  }

  OniStatus
  initialize (oni::driver::DeviceConnectedCallback connected, oni::driver::DeviceDisconnectedCallback disconnected,
              oni::driver::DeviceStateChangedCallback state_changed, void* cookie) override
  {
    const OniStatus rc = DriverBase::initialize (connected, disconnected, state_changed, cookie);
    if (rc != ONI_STATUS_OK)
      return rc;
    announced_ = readConfig ().enabled;
    if (announced_)
      deviceConnected (&info_);
    else
      log (kLogInfo, "hidden (PCLX_VIRTUAL_CAMERA=0 or enabled = 0 in the config file)");
    return ONI_STATUS_OK;
  }

  oni::driver::DeviceBase*
  deviceOpen (const char* uri, const char* /*mode*/) override
  {
    if (!announced_ || !uri || std::strcmp (uri, kUri) != 0)
      return nullptr;
    std::lock_guard<std::mutex> lock (mutex_);
    if (device_)
      return device_;
    std::string error;
    std::unique_ptr<FrameSource> source = openSource (readConfig (), error);
    if (!source)
    {
      // The error logger feeds openni::OpenNI::getExtendedError (), which PCL puts in its exception.
      getServices ().errorLoggerAppend ("pclx virtual camera: cannot open: %s", error.c_str ());
      log (kLogError, "cannot open: %s", error.c_str ());
      return nullptr;
    }
    device_ = new (std::nothrow) VirtualDevice (*this, std::move (source));
    if (device_)
      log (kLogInfo, "opened: %s", device_->source ().description ().c_str ());
    return device_;
  }

  void
  deviceClose (oni::driver::DeviceBase* device) override
  {
    bool recovered = false;
    {
      std::lock_guard<std::mutex> lock (mutex_);
      if (device != device_)
        return;
      device_->destroyAllStreams ();  // joins the frame thread: failed () is final after it
      recovered = device_->failed ();
      delete device_;
      device_ = nullptr;
    }
    // A virtual camera comes back when its failed instance is closed: the next open reads the
    // configuration again (and fails cleanly if the folder is still missing).
    if (recovered)
      deviceStateChanged (&info_, ONI_DEVICE_STATE_OK);
  }

  OniStatus
  tryDevice (const char* uri) override
  {
    return announced_ && uri && std::strcmp (uri, kUri) == 0 ? ONI_STATUS_OK : ONI_STATUS_ERROR;
  }

  void
  shutdown () override
  {
    std::lock_guard<std::mutex> lock (mutex_);
    delete device_;
    device_ = nullptr;
  }

  // Frame sync is refused. Our streams already share frame indices and timestamps, and OpenNI's
  // SyncedStreamsFrameHolder can block its callback thread forever when a stream stops between
  // a frame event and the read (then stream destruction cancels that thread and double-frees):
  // see the README. Refused, OpenNI keeps the per-stream holders, which do not block.
  void*
  enableFrameSync (oni::driver::StreamBase** /*streams*/, int /*count*/) override
  {
    log (kLogInfo, "depth/colour frame sync refused (frames already share indices and timestamps)");
    return nullptr;
  }

  void
  disableFrameSync (void* /*group*/) override
  {}

  void
  reportError ()
  {
    deviceStateChanged (&info_, ONI_DEVICE_STATE_ERROR);
  }

  void
  log (int severity, const char* format, ...)
  {
    char message[1024];
    va_list args;
    va_start (args, format);
    std::vsnprintf (message, sizeof (message), format, args);
    va_end (args);
    getServices ().log (severity, __FILE__, __LINE__, kMask, message);
    // OpenNI's own log is off by default (OpenNI.ini); errors must reach the user anyway.
    if (severity >= kLogWarning)
      std::fprintf (stderr, "[pclx virtual camera] %s\n", message);
  }

private:
  OniDeviceInfo info_;
  bool announced_ = false;
  std::mutex mutex_;
  VirtualDevice* device_ = nullptr;
};

// ----------------------------------------------------------------------------------------------

VirtualDevice::VirtualDevice (VirtualDriver& driver, std::unique_ptr<FrameSource> source)
  : driver_ (driver), source_ (std::move (source))
{
  const OniSensorType types[2] = {ONI_SENSOR_DEPTH, ONI_SENSOR_COLOR};
  for (int s = 0; s < 2; ++s)
  {
    for (const auto& [w, h] : source_->resolutions ())
    {
      OniVideoMode m;
      m.pixelFormat = types[s] == ONI_SENSOR_DEPTH ? ONI_PIXEL_FORMAT_DEPTH_1_MM : ONI_PIXEL_FORMAT_RGB888;
      m.resolutionX = w;
      m.resolutionY = h;
      m.fps = kFps;
      modes_[s].push_back (m);
    }
    sensors_[s].sensorType = types[s];
    sensors_[s].numSupportedVideoModes = int (modes_[s].size ());
    sensors_[s].pSupportedVideoModes = modes_[s].data ();
  }
}

VirtualDevice::~VirtualDevice ()
{
  destroyAllStreams ();
}

void
VirtualDevice::destroyAllStreams ()
{
  // OpenNI destroys streams before closing the device; this is the safety net.
  std::vector<VirtualStream*> left;
  {
    std::lock_guard<std::mutex> lock (mutex_);
    left = streams_;
  }
  for (VirtualStream* s : left)
    destroyStream (s);
}

oni::driver::StreamBase*
VirtualDevice::createStream (OniSensorType type)
{
  if (type != ONI_SENSOR_DEPTH && type != ONI_SENSOR_COLOR)
  {
    driver_.log (kLogWarning, "no sensor of type %d (depth and colour only)", int (type));
    return nullptr;
  }
  auto* s = new (std::nothrow) VirtualStream (*this, type, modes_[type == ONI_SENSOR_DEPTH ? 0 : 1][0]);
  if (s)
  {
    std::lock_guard<std::mutex> lock (mutex_);
    streams_.push_back (s);
  }
  return s;
}

void
VirtualDevice::destroyStream (oni::driver::StreamBase* stream)
{
  auto* s = static_cast<VirtualStream*> (stream);
  s->stop ();
  {
    std::lock_guard<std::mutex> lock (mutex_);
    streams_.erase (std::remove (streams_.begin (), streams_.end (), s), streams_.end ());
  }
  delete s;
}

bool
VirtualDevice::supports (OniSensorType type, const OniVideoMode& m) const
{
  for (const OniVideoMode& s : modes_[type == ONI_SENSOR_DEPTH ? 0 : 1])
    if (s.pixelFormat == m.pixelFormat && s.resolutionX == m.resolutionX && s.resolutionY == m.resolutionY &&
        s.fps == m.fps)
      return true;
  return false;
}

OniBool
VirtualDevice::isPropertySupported (int id)
{
  switch (id)
  {
    case ONI_DEVICE_PROPERTY_IMAGE_REGISTRATION:
    case ONI_DEVICE_PROPERTY_DRIVER_VERSION:
    case ONI_DEVICE_PROPERTY_FIRMWARE_VERSION:
    case ONI_DEVICE_PROPERTY_HARDWARE_VERSION:
    case ONI_DEVICE_PROPERTY_SERIAL_NUMBER:
      return TRUE;
    default:
      return FALSE;
  }
}

OniStatus
VirtualDevice::getProperty (int id, void* data, int* size)
{
  switch (id)
  {
    case ONI_DEVICE_PROPERTY_IMAGE_REGISTRATION: {
      std::lock_guard<std::mutex> lock (mutex_);
      return readValue (data, size, registration_);
    }
    case ONI_DEVICE_PROPERTY_DRIVER_VERSION: {
      OniVersion v;
      v.major = 0;
      v.minor = 1;
      v.maintenance = 0;
      v.build = 0;
      return readValue (data, size, v);
    }
    case ONI_DEVICE_PROPERTY_FIRMWARE_VERSION:
      return readString (data, size, "pclx virtual 0.1");
    case ONI_DEVICE_PROPERTY_HARDWARE_VERSION:
      return readValue (data, size, 0);
    case ONI_DEVICE_PROPERTY_SERIAL_NUMBER:
      return readString (data, size, "pclx-virtual-0");
    default:
      return ONI_STATUS_NOT_SUPPORTED;
  }
}

OniStatus
VirtualDevice::setProperty (int id, const void* data, int size)
{
  if (id != ONI_DEVICE_PROPERTY_IMAGE_REGISTRATION)
    return ONI_STATUS_NOT_SUPPORTED;
  if (size != int (sizeof (OniImageRegistrationMode)))
    return ONI_STATUS_BAD_PARAMETER;
  OniImageRegistrationMode mode;
  std::memcpy (&mode, data, sizeof (mode));
  if (!isImageRegistrationModeSupported (mode))
    return ONI_STATUS_NOT_SUPPORTED;
  // Rendered and synthesised colour is already pixel-aligned with depth: nothing to warp.
  std::lock_guard<std::mutex> lock (mutex_);
  registration_ = mode;
  return ONI_STATUS_OK;
}

OniStatus
VirtualDevice::startStream (VirtualStream* stream)
{
  std::unique_lock<std::mutex> lock (mutex_);
  if (failed_)
  {
    lock.unlock ();
    driver_.log (kLogError, "cannot start a stream: the device is in the error state (source gone)");
    return ONI_STATUS_ERROR;
  }
  if (std::find (active_.begin (), active_.end (), stream) == active_.end ())
    active_.push_back (stream);
  if (!thread_.joinable ())
    thread_ = std::thread (&VirtualDevice::run, this, generation_);
  return ONI_STATUS_OK;
}

void
VirtualDevice::stopStream (VirtualStream* stream)
{
  std::thread finished;
  {
    std::unique_lock<std::mutex> lock (mutex_);
    active_.erase (std::remove (active_.begin (), active_.end (), stream), active_.end ());
    // After this wait the frame thread no longer touches `stream` (it may be deleted next).
    // The frame thread itself never stops streams, so it cannot wait on itself here.
    if (std::this_thread::get_id () != thread_.get_id ())
      cv_.wait (lock, [this] { return !delivering_; });
    if (active_.empty () && thread_.joinable () && std::this_thread::get_id () != thread_.get_id ())
    {
      ++generation_;
      cv_.notify_all ();
      finished = std::move (thread_);
    }
  }
  if (finished.joinable ())
    finished.join ();
}

void
VirtualDevice::run (int generation)
{
  const auto retired = [this, generation] { return generation_ != generation; };
  const auto period = std::chrono::microseconds (1000000 / kFps);
  auto next = Clock::now ();
  std::map<std::pair<int, int>, Frame> frames;  // one render per distinct output size
  std::string error;
  std::unique_lock<std::mutex> lock (mutex_);
  while (!retired ())
  {
    // Pacing and the unplugged idle both sleep on the condition variable: stop () wakes them.
    if (failed_)
    {
      cv_.wait (lock, retired);
      break;
    }
    if (cv_.wait_until (lock, next, retired))
      break;
    const std::vector<VirtualStream*> targets = active_;
    const int index = next_index_++;
    delivering_ = true;
    lock.unlock ();

    // One render per distinct output size, with colour when a colour stream has that size.
    std::map<std::pair<int, int>, bool> sizes;
    for (VirtualStream* s : targets)
    {
      const OniVideoMode m = s->mode ();
      sizes[{m.resolutionX, m.resolutionY}] |= s->type () == ONI_SENSOR_COLOR;
    }
    frames.clear ();
    bool ok = true;
    for (const auto& [size, colour] : sizes)
      if (ok)
        ok = source_->render (std::uint64_t (index - 1), size.first, size.second, colour, frames[size], error);
    const std::uint64_t stamp =
      std::uint64_t (std::chrono::duration_cast<std::chrono::microseconds> (Clock::now () - epoch_).count ());
    if (ok)
      for (VirtualStream* s : targets)
      {
        const OniVideoMode m = s->mode ();
        s->deliver (frames[{m.resolutionX, m.resolutionY}], index, stamp);
      }
    else
    {
      // Marked failed before the event goes out, so whoever reacts to it sees the state.
      {
        std::lock_guard<std::mutex> relock (mutex_);
        failed_ = true;
      }
      driver_.log (kLogError, "stopped streaming: %s%s", error.c_str (),
                   source_->present () ? "" : " (the recording folder is gone: device unplugged)");
      driver_.reportError ();
    }

    lock.lock ();
    delivering_ = false;
    cv_.notify_all ();
    // Late frames are not made up in a burst: the clock restarts from now.
    next += period;
    if (next < Clock::now ())
      next = Clock::now ();
  }
}

// ----------------------------------------------------------------------------------------------

VirtualStream::~VirtualStream ()
{
  stop ();
}

OniStatus
VirtualStream::start ()
{
  {
    std::lock_guard<std::mutex> lock (mutex_);
    if (started_)
      return ONI_STATUS_OK;
    started_ = true;
  }
  const OniStatus rc = device_.startStream (this);
  if (rc != ONI_STATUS_OK)
  {
    std::lock_guard<std::mutex> lock (mutex_);
    started_ = false;
  }
  return rc;
}

void
VirtualStream::stop ()
{
  {
    std::lock_guard<std::mutex> lock (mutex_);
    if (!started_)
      return;
    started_ = false;
  }
  device_.stopStream (this);
}

OniBool
VirtualStream::isPropertySupported (int id)
{
  switch (id)
  {
    case ONI_STREAM_PROPERTY_VIDEO_MODE:
    case ONI_STREAM_PROPERTY_HORIZONTAL_FOV:
    case ONI_STREAM_PROPERTY_VERTICAL_FOV:
    case ONI_STREAM_PROPERTY_MAX_VALUE:
    case ONI_STREAM_PROPERTY_MIN_VALUE:
    case ONI_STREAM_PROPERTY_STRIDE:
    case ONI_STREAM_PROPERTY_MIRRORING:
      return TRUE;
    case XN_STREAM_PROPERTY_EMITTER_DCMOS_DISTANCE:
    case XN_STREAM_PROPERTY_ZERO_PLANE_DISTANCE:
    case XN_STREAM_PROPERTY_ZERO_PLANE_PIXEL_SIZE:
      return type_ == ONI_SENSOR_DEPTH;
    default:  // cropping included: only its "off" state can be read or set
      return FALSE;
  }
}

OniStatus
VirtualStream::getProperty (int id, void* data, int* size)
{
  const CameraModel& cam = device_.source ().camera ();
  std::lock_guard<std::mutex> lock (mutex_);
  const bool depth = type_ == ONI_SENSOR_DEPTH;
  switch (id)
  {
    case ONI_STREAM_PROPERTY_VIDEO_MODE:
      return readValue (data, size, mode_);
    case ONI_STREAM_PROPERTY_HORIZONTAL_FOV:
      return readValue (data, size, cam.horizontalFov ());
    case ONI_STREAM_PROPERTY_VERTICAL_FOV:
      return readValue (data, size, cam.verticalFov ());
    case ONI_STREAM_PROPERTY_MAX_VALUE:
      return readValue (data, size, depth ? device_.source ().maxDepth () : 255);
    case ONI_STREAM_PROPERTY_MIN_VALUE:
      return readValue (data, size, 0);
    case ONI_STREAM_PROPERTY_STRIDE:
      return readValue (data, size, mode_.resolutionX * bytesPerPixel (mode_.pixelFormat));
    case ONI_STREAM_PROPERTY_MIRRORING:
      return readValue (data, size, OniBool (mirror_ ? TRUE : FALSE));
    case ONI_STREAM_PROPERTY_CROPPING: {
      // Not supported, but readable as "off": openni::Recorder writes xnCropping only when this
      // succeeds, and Debian's OniFile player drops every frame of a stream without it.
      OniCropping off;
      off.enabled = FALSE;
      off.originX = off.originY = 0;
      off.width = mode_.resolutionX;
      off.height = mode_.resolutionY;
      return readValue (data, size, off);
    }
    default:
      break;
  }
  if (!depth)
    return ONI_STATUS_NOT_SUPPORTED;
  // PS1080 depth properties: PCL 1.13 reads the baseline; OpenNI 1-style users derive the
  // focal length as ZPD / ZPPS at SXGA (twice the VGA focal length).
  switch (id)
  {
    case XN_STREAM_PROPERTY_EMITTER_DCMOS_DISTANCE:
      return readValue (data, size, kBaselineCm);
    case XN_STREAM_PROPERTY_ZERO_PLANE_DISTANCE:
      return readValue (data, size, std::uint64_t (kZeroPlaneDistanceMm));
    case XN_STREAM_PROPERTY_ZERO_PLANE_PIXEL_SIZE:
      return readValue (data, size, double (kZeroPlaneDistanceMm) / (2.0 * cam.fx * 640.0 / cam.width));
    default:
      return ONI_STATUS_NOT_SUPPORTED;
  }
}

OniStatus
VirtualStream::setProperty (int id, const void* data, int size)
{
  std::lock_guard<std::mutex> lock (mutex_);
  if (id == ONI_STREAM_PROPERTY_MIRRORING)
  {
    if (size != int (sizeof (OniBool)))
      return ONI_STATUS_BAD_PARAMETER;
    OniBool on;
    std::memcpy (&on, data, sizeof (on));
    mirror_ = on != FALSE;
    return ONI_STATUS_OK;
  }
  if (id == ONI_STREAM_PROPERTY_CROPPING)
  {
    if (size != int (sizeof (OniCropping)))
      return ONI_STATUS_BAD_PARAMETER;
    OniCropping c;
    std::memcpy (&c, data, sizeof (c));
    return c.enabled ? ONI_STATUS_NOT_SUPPORTED : ONI_STATUS_OK;
  }
  if (id == ONI_STREAM_PROPERTY_VIDEO_MODE)
  {
    if (size != int (sizeof (OniVideoMode)))
      return ONI_STATUS_BAD_PARAMETER;
    OniVideoMode m;
    std::memcpy (&m, data, sizeof (m));
    if (!device_.supports (type_, m))
    {
      device_.log (kLogWarning, "unsupported video mode %dx%d@%d format %d", m.resolutionX, m.resolutionY,
                   m.fps, int (m.pixelFormat));
      return ONI_STATUS_NOT_SUPPORTED;
    }
    // OpenNI sized the frame buffers at start: a running stream keeps its mode.
    if (started_ && (m.resolutionX != mode_.resolutionX || m.resolutionY != mode_.resolutionY))
      return ONI_STATUS_OUT_OF_FLOW;
    mode_ = m;
    return ONI_STATUS_OK;
  }
  return ONI_STATUS_NOT_SUPPORTED;
}

void
VirtualStream::deliver (const Frame& frame, int index, std::uint64_t timestamp_us)
{
  OniVideoMode m;
  bool mirror;
  {
    std::lock_guard<std::mutex> lock (mutex_);
    m = mode_;
    mirror = mirror_;
  }
  OniFrame* f = getServices ().acquireFrame ();
  if (!f)
    return;
  const int bpp = bytesPerPixel (m.pixelFormat);
  const int w = frame.width, h = frame.height;
  if (w != m.resolutionX || h != m.resolutionY || (type_ == ONI_SENSOR_COLOR && frame.rgb.empty ()))
  {
    getServices ().releaseFrame (f);
    return;
  }
  const std::size_t row = std::size_t (w) * bpp;
  auto* dst = static_cast<std::uint8_t*> (f->data);
  const auto* src = type_ == ONI_SENSOR_DEPTH ? reinterpret_cast<const std::uint8_t*> (frame.depth.data ())
                                              : frame.rgb.data ();
  for (int y = 0; y < h; ++y)
  {
    std::uint8_t* d = dst + row * y;
    const std::uint8_t* s = src + row * y;
    if (!mirror)
      std::memcpy (d, s, row);
    else
      for (int x = 0; x < w; ++x)
        std::memcpy (d + std::size_t (x) * bpp, s + std::size_t (w - 1 - x) * bpp, std::size_t (bpp));
  }
  f->dataSize = int (row * h);
  f->sensorType = type_;
  f->timestamp = timestamp_us;
  f->frameIndex = index;
  f->videoMode = m;
  f->width = w;
  f->height = h;
  f->cropOriginX = f->cropOriginY = 0;
  f->croppingEnabled = FALSE;
  f->stride = int (row);
  raiseNewFrame (f);
  getServices ().releaseFrame (f);
}

void
VirtualDevice::log (int severity, const char* format, ...)
{
  char message[1024];
  va_list args;
  va_start (args, format);
  std::vsnprintf (message, sizeof (message), format, args);
  va_end (args);
  driver_.log (severity, "%s", message);
}

}  // namespace openni2_virtual
}  // namespace pclx

ONI_EXPORT_DRIVER (pclx::openni2_virtual::VirtualDriver);

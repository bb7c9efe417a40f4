#include "png_io.h"

#include <png.h>

#include <csetjmp>
#include <cstdio>
#include <cstring>

namespace pclx {
namespace openni2_virtual {

namespace {

struct ErrorSink
{
  char message[256] = {0};
};

void
onPngError (png_structp png, png_const_charp msg)
{
  auto* sink = static_cast<ErrorSink*> (png_get_error_ptr (png));
  std::snprintf (sink->message, sizeof (sink->message), "%s", msg);
  png_longjmp (png, 1);
}

void
onPngWarning (png_structp, png_const_charp)
{
  // Warnings (e.g. an unknown chunk) do not make a frame unusable.
}

// Owns the FILE and the libpng structures, so every exit path (longjmp included) releases them.
struct Reader
{
  std::FILE* file = nullptr;
  png_structp png = nullptr;
  png_infop info = nullptr;
  ErrorSink sink;

  ~Reader ()
  {
    if (png)
      png_destroy_read_struct (&png, info ? &info : nullptr, nullptr);
    if (file)
      std::fclose (file);
  }

  bool
  open (const std::string& path, std::string& error)
  {
    file = std::fopen (path.c_str (), "rb");
    if (!file)
    {
      error = "cannot open " + path + ": " + std::strerror (errno);
      return false;
    }
    png_byte sig[8];
    if (std::fread (sig, 1, 8, file) != 8 || png_sig_cmp (sig, 0, 8) != 0)
    {
      error = path + " is not a PNG file";
      return false;
    }
    png = png_create_read_struct (PNG_LIBPNG_VER_STRING, &sink, onPngError, onPngWarning);
    info = png ? png_create_info_struct (png) : nullptr;
    if (!info)
    {
      error = "libpng could not allocate its structures";
      return false;
    }
    png_init_io (png, file);
    png_set_sig_bytes (png, 8);
    return true;
  }
};

// Row reading shared by both pixel formats; `setup` runs inside the setjmp scope.
template <typename Setup>
bool
readRows (Reader& r, const std::string& path, std::vector<png_byte>& pixels, int& width, int& height,
          int expected_channels, int expected_bytes, Setup setup, std::string& error)
{
  std::vector<png_bytep> rows;
  if (setjmp (png_jmpbuf (r.png)))
  {
    error = "corrupt PNG " + path + ": " + r.sink.message;
    return false;
  }
  png_read_info (r.png, r.info);
  if (!setup ())
  {
    error = path + ": " + r.sink.message;
    return false;
  }
  png_read_update_info (r.png, r.info);
  width = int (png_get_image_width (r.png, r.info));
  height = int (png_get_image_height (r.png, r.info));
  const int channels = png_get_channels (r.png, r.info);
  const int bytes = png_get_bit_depth (r.png, r.info) / 8;
  if (channels != expected_channels || bytes != expected_bytes || width <= 0 || height <= 0)
  {
    error = path + ": unexpected pixel layout after conversion";
    return false;
  }
  const std::size_t stride = png_get_rowbytes (r.png, r.info);
  pixels.resize (stride * std::size_t (height));
  rows.resize (std::size_t (height));
  for (int y = 0; y < height; ++y)
    rows[y] = pixels.data () + stride * std::size_t (y);
  png_read_image (r.png, rows.data ());
  png_read_end (r.png, nullptr);
  return true;
}

template <typename Fill>
bool
writePng (const std::string& path, int width, int height, int bit_depth, int color_type, int row_bytes,
          Fill fill, std::string& error)
{
  std::FILE* file = std::fopen (path.c_str (), "wb");
  if (!file)
  {
    error = "cannot create " + path + ": " + std::strerror (errno);
    return false;
  }
  ErrorSink sink;
  png_structp png = png_create_write_struct (PNG_LIBPNG_VER_STRING, &sink, onPngError, onPngWarning);
  png_infop info = png ? png_create_info_struct (png) : nullptr;
  std::vector<png_byte> row (static_cast<std::size_t> (row_bytes));
  volatile bool ok = false;  // read after a possible longjmp
  if (info && !setjmp (png_jmpbuf (png)))
  {
    png_init_io (png, file);
    png_set_IHDR (png, info, png_uint_32 (width), png_uint_32 (height), bit_depth, color_type,
                  PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_compression_level (png, 1);
    png_write_info (png, info);
    for (int y = 0; y < height; ++y)
    {
      fill (y, row.data ());
      png_write_row (png, row.data ());
    }
    png_write_end (png, nullptr);
    ok = true;
  }
  else
    error = "cannot write " + path + ": " + sink.message;
  if (png)
    png_destroy_write_struct (&png, info ? &info : nullptr);
  if (std::fclose (file) != 0 && ok)
  {
    error = "cannot write " + path + ": " + std::strerror (errno);
    ok = false;
  }
  return ok;
}

}  // namespace

bool
readPngInfo (const std::string& path, PngInfo& out, std::string& error)
{
  Reader r;
  if (!r.open (path, error))
    return false;
  if (setjmp (png_jmpbuf (r.png)))
  {
    error = "corrupt PNG " + path + ": " + r.sink.message;
    return false;
  }
  png_read_info (r.png, r.info);
  out.width = int (png_get_image_width (r.png, r.info));
  out.height = int (png_get_image_height (r.png, r.info));
  out.bit_depth = png_get_bit_depth (r.png, r.info);
  const int type = png_get_color_type (r.png, r.info);
  out.channels = type == PNG_COLOR_TYPE_PALETTE ? 3 : png_get_channels (r.png, r.info);
  return true;
}

bool
readPngDepth (const std::string& path, std::vector<std::uint16_t>& depth, int& width, int& height,
              std::string& error)
{
  Reader r;
  if (!r.open (path, error))
    return false;
  std::vector<png_byte> pixels;
  const bool ok = readRows (r, path, pixels, width, height, 1, 2, [&r] () {
    if (png_get_color_type (r.png, r.info) != PNG_COLOR_TYPE_GRAY || png_get_bit_depth (r.png, r.info) != 16)
    {
      std::snprintf (r.sink.message, sizeof (r.sink.message),
                     "a depth frame must be a 16-bit grayscale PNG (colour type %d, %d bits)",
                     int (png_get_color_type (r.png, r.info)), int (png_get_bit_depth (r.png, r.info)));
      return false;
    }
    png_set_swap (r.png);  // PNG stores 16-bit samples big-endian
    return true;
  }, error);
  if (!ok)
    return false;
  depth.resize (std::size_t (width) * std::size_t (height));
  std::memcpy (depth.data (), pixels.data (), depth.size () * sizeof (std::uint16_t));
  return true;
}

bool
readPngRgb (const std::string& path, std::vector<std::uint8_t>& rgb, int& width, int& height, std::string& error)
{
  Reader r;
  if (!r.open (path, error))
    return false;
  std::vector<png_byte> pixels;
  const bool ok = readRows (r, path, pixels, width, height, 3, 1, [&r] () {
    const int type = png_get_color_type (r.png, r.info);
    if (type == PNG_COLOR_TYPE_PALETTE)
      png_set_palette_to_rgb (r.png);
    if (type == PNG_COLOR_TYPE_GRAY || type == PNG_COLOR_TYPE_GRAY_ALPHA)
    {
      png_set_expand_gray_1_2_4_to_8 (r.png);
      png_set_gray_to_rgb (r.png);
    }
    if (png_get_valid (r.png, r.info, PNG_INFO_tRNS))
      png_set_tRNS_to_alpha (r.png);
    png_set_strip_16 (r.png);
    png_set_strip_alpha (r.png);
    return true;
  }, error);
  if (!ok)
    return false;
  rgb.assign (pixels.begin (), pixels.end ());
  return true;
}

bool
writePngDepth (const std::string& path, const std::vector<std::uint16_t>& depth, int width, int height,
               std::string& error)
{
  if (depth.size () != std::size_t (width) * std::size_t (height))
  {
    error = "depth buffer size does not match " + std::to_string (width) + "x" + std::to_string (height);
    return false;
  }
  return writePng (path, width, height, 16, PNG_COLOR_TYPE_GRAY, width * 2, [&] (int y, png_bytep row) {
    const std::uint16_t* src = depth.data () + std::size_t (y) * std::size_t (width);
    for (int x = 0; x < width; ++x)
    {
      row[2 * x] = png_byte (src[x] >> 8);
      row[2 * x + 1] = png_byte (src[x] & 0xff);
    }
  }, error);
}

bool
writePngRgb (const std::string& path, const std::vector<std::uint8_t>& rgb, int width, int height,
             std::string& error)
{
  if (rgb.size () != std::size_t (width) * std::size_t (height) * 3)
  {
    error = "RGB buffer size does not match " + std::to_string (width) + "x" + std::to_string (height);
    return false;
  }
  return writePng (path, width, height, 8, PNG_COLOR_TYPE_RGB, width * 3, [&] (int y, png_bytep row) {
    std::memcpy (row, rgb.data () + std::size_t (y) * std::size_t (width) * 3, std::size_t (width) * 3);
  }, error);
}

}  // namespace openni2_virtual
}  // namespace pclx

#include "hal/codec/png_io.hpp"

#include <png.h>

#include <csetjmp>
#include <cstdio>
#include <vector>

namespace zonemap::hal {
namespace {

struct ErrorSink {
  char message[256] = {0};
};

void on_png_error(png_structp png, png_const_charp message) {
  auto* sink = static_cast<ErrorSink*>(png_get_error_ptr(png));
  std::snprintf(sink->message, sizeof(sink->message), "%s", message);
  png_longjmp(png, 1);
}

void on_png_warning(png_structp, png_const_charp) {}

class File {
 public:
  File(const std::string& path, const char* mode) : file_(std::fopen(path.c_str(), mode)) {}
  ~File() {
    if (file_ != nullptr) std::fclose(file_);
  }
  File(const File&) = delete;
  File& operator=(const File&) = delete;
  std::FILE* get() const { return file_; }
  // Closes and reports whether every buffered byte reached the file.
  bool close() {
    const bool ok = file_ != nullptr && std::fclose(file_) == 0;
    file_ = nullptr;
    return ok;
  }

 private:
  std::FILE* file_;
};

// All C++ objects live in the callers, outside the setjmp frame below, so that
// libpng's longjmp never skips a destructor.
bool decode(std::FILE* file, int width, int height, int bit_depth, png_bytep* rows, ErrorSink* sink,
            int* got_width, int* got_height, int* got_depth, int* got_color) {
  png_structp png =
      png_create_read_struct(PNG_LIBPNG_VER_STRING, sink, on_png_error, on_png_warning);
  if (png == nullptr) return false;
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_init_io(png, file);
  png_read_info(png, info);
  *got_width = static_cast<int>(png_get_image_width(png, info));
  *got_height = static_cast<int>(png_get_image_height(png, info));
  *got_depth = png_get_bit_depth(png, info);
  *got_color = png_get_color_type(png, info);
  if (*got_width != width || *got_height != height || *got_depth != bit_depth ||
      *got_color != PNG_COLOR_TYPE_GRAY) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  if (bit_depth == 16) {
    const unsigned probe = 1;
    if (*reinterpret_cast<const unsigned char*>(&probe) == 1) png_set_swap(png);
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  png_read_image(png, rows);
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

bool read_gray(const std::string& path, int width, int height, int bit_depth, void* out,
               std::string* error) {
  File file(path, "rb");
  if (file.get() == nullptr) {
    *error = path + ": cannot open";
    return false;
  }
  unsigned char signature[8] = {0};
  if (std::fread(signature, 1, 8, file.get()) != 8 || png_sig_cmp(signature, 0, 8) != 0) {
    *error = path + ": not a PNG file";
    return false;
  }
  std::rewind(file.get());
  const std::size_t row_bytes = static_cast<std::size_t>(width) * (bit_depth / 8);
  std::vector<png_bytep> rows(static_cast<std::size_t>(height));
  for (int y = 0; y < height; ++y) {
    rows[static_cast<std::size_t>(y)] = static_cast<png_bytep>(out) + y * row_bytes;
  }
  ErrorSink sink;
  int got_width = 0, got_height = 0, got_depth = 0, got_color = -1;
  if (decode(file.get(), width, height, bit_depth, rows.data(), &sink, &got_width, &got_height,
             &got_depth, &got_color)) {
    return true;
  }
  if (sink.message[0] != 0) {
    *error = path + ": corrupt PNG (" + sink.message + ")";
  } else if (got_color != PNG_COLOR_TYPE_GRAY && got_color != -1) {
    *error = path + ": expected a single-channel (grey) PNG";
  } else if (got_depth != bit_depth) {
    *error = path + ": expected " + std::to_string(bit_depth) + "-bit PNG, found " +
             std::to_string(got_depth) + "-bit";
  } else {
    *error = path + ": expected " + std::to_string(width) + "x" + std::to_string(height) +
             ", found " + std::to_string(got_width) + "x" + std::to_string(got_height);
  }
  return false;
}

bool encode(std::FILE* file, int width, int height, int bit_depth, int color_type, png_bytep* rows,
            ErrorSink* sink) {
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, sink, on_png_error, on_png_warning);
  if (png == nullptr) return false;
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_init_io(png, file);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height),
               bit_depth, color_type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(png, 3);
  png_write_info(png, info);
  if (bit_depth == 16) {
    const unsigned probe = 1;
    if (*reinterpret_cast<const unsigned char*>(&probe) == 1) png_set_swap(png);
  }
  png_write_image(png, rows);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

bool write_image(const std::string& path, int width, int height, int bit_depth, int channels,
                 const void* pixels, std::string* error) {
  File file(path, "wb");
  if (file.get() == nullptr) {
    *error = path + ": cannot create";
    return false;
  }
  const std::size_t row_bytes = static_cast<std::size_t>(width) * channels * (bit_depth / 8);
  std::vector<png_bytep> rows(static_cast<std::size_t>(height));
  for (int y = 0; y < height; ++y) {
    rows[static_cast<std::size_t>(y)] =
        const_cast<png_bytep>(static_cast<const unsigned char*>(pixels)) + y * row_bytes;
  }
  ErrorSink sink;
  const int color = channels == 3 ? PNG_COLOR_TYPE_RGB : PNG_COLOR_TYPE_GRAY;
  if (!encode(file.get(), width, height, bit_depth, color, rows.data(), &sink) || !file.close()) {
    *error = path + ": cannot write PNG" +
             (sink.message[0] ? std::string(" (") + sink.message + ")" : "");
    return false;
  }
  return true;
}

}  // namespace

bool read_png_gray16(const std::string& path, int width, int height, std::uint16_t* out,
                     std::string* error) {
  return read_gray(path, width, height, 16, out, error);
}
bool read_png_gray8(const std::string& path, int width, int height, std::uint8_t* out,
                    std::string* error) {
  return read_gray(path, width, height, 8, out, error);
}
bool write_png_gray16(const std::string& path, int width, int height, const std::uint16_t* pixels,
                      std::string* error) {
  return write_image(path, width, height, 16, 1, pixels, error);
}
bool write_png_gray8(const std::string& path, int width, int height, const std::uint8_t* pixels,
                     std::string* error) {
  return write_image(path, width, height, 8, 1, pixels, error);
}
bool write_png_rgb8(const std::string& path, int width, int height, const std::uint8_t* pixels,
                    std::string* error) {
  return write_image(path, width, height, 8, 3, pixels, error);
}

}  // namespace zonemap::hal

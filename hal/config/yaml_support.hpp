// Strict YAML reading shared by the configuration loaders: every key known,
// every error naming file and line. Not on the real-time path.
#pragma once

#include <yaml-cpp/yaml.h>

#include <exception>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace zonemap::hal {

inline std::string where(const std::string& path, const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  return path + ":" + std::to_string(mark.line + 1);
}

// One section of a YAML mapping: each known key has a reader; any other key is an error.
using Reader = std::function<void(const YAML::Node&)>;

struct ParseError {
  std::string message;
};

inline void read_section(const std::string& path, const YAML::Node& section,
                         const std::string& name, const std::map<std::string, Reader>& readers) {
  if (!section.IsMap()) {
    throw ParseError{where(path, section) + ": '" + name + "' must be a mapping"};
  }
  for (const auto& item : section) {
    const std::string key = item.first.as<std::string>();
    const auto reader = readers.find(key);
    if (reader == readers.end()) {
      throw ParseError{where(path, item.first) + ": unknown key '" + key + "'" +
                       (name.empty() ? "" : " in '" + name + "'")};
    }
    try {
      reader->second(item.second);
    } catch (const YAML::Exception&) {
      throw ParseError{where(path, item.second) + ": bad value for '" + key + "'"};
    }
  }
}

template <typename T>
Reader into(T* target) {
  return [target](const YAML::Node& node) { *target = node.as<T>(); };
}

// A setting that names one of a few choices: `key` (for the message) must be one
// of `names`, which set *target to the value beside it.
template <typename E>
Reader one_of(const std::string& path, const std::string& key, E* target,
              std::vector<std::pair<std::string, E>> names) {
  return [path, key, target, names](const YAML::Node& node) {
    const std::string v = node.as<std::string>();
    std::string allowed;
    for (const auto& [name, value] : names) {
      if (v == name) {
        *target = value;
        return;
      }
      allowed += (allowed.empty() ? "'" : " or '") + name + "'";
    }
    throw ParseError{where(path, node) + ": " + key + " must be " + allowed};
  };
}

// Runs `read`, which reports a problem by throwing ParseError (already naming
// file and line) or YAML::Exception (a wrong type, a bad document): false with
// the message in *error then.
template <typename Read>
bool read_explained(const std::string& path, std::string* error, Read read) {
  try {
    read();
    return true;
  } catch (const ParseError& e) {
    *error = e.message;
  } catch (const YAML::Exception& e) {
    *error = path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg;
  }
  return false;
}

inline bool load_file(const std::string& path, YAML::Node* root, std::string* error) {
  // A directory opens as a stream on Linux and throws std::ios_base::failure on the first
  // read, which is no YAML::Exception.
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    *error = path + ": a directory, not a file";
    return false;
  }
  try {
    *root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    *error = path + ": cannot open";
    return false;
  } catch (const YAML::Exception& e) {
    *error = path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg;
    return false;
  } catch (const std::exception& e) {
    *error = path + ": cannot read (" + e.what() + ")";
    return false;
  }
  return true;
}

inline bool load_text(const std::string& text, const std::string& name, YAML::Node* root,
                      std::string* error) {
  try {
    *root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    *error = name + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg;
    return false;
  }
  return true;
}

}  // namespace zonemap::hal

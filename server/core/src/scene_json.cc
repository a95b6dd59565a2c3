#include "scene_json.h"

#include <string>
#include <utility>
#include <vector>

#include "dysa/core/text.h"
#include "dysa/core/types.h"

namespace dysa {
namespace {

using nlohmann::json;

// nlohmann's SAX interface, building the document as json::parse does while knowing the path of
// the value being read, so that a number the parser refuses (1e999) is named by its field, and
// checking what json::parse lets through: numbers that round to 0 and unbounded nesting.
class PathTrackingBuilder {
 public:
  bool null() { return Add(json(nullptr)); }
  bool boolean(bool value) { return Add(json(value)); }
  bool number_integer(json::number_integer_t value) { return Add(json(value)); }
  bool number_unsigned(json::number_unsigned_t value) { return Add(json(value)); }
  bool number_float(json::number_float_t value, const std::string& text) {
    // strtod rounds a nonzero number below the smallest subnormal (4.9e-324) to 0.
    if (value == 0 &&
        text.substr(0, text.find_first_of("eE")).find_first_of("123456789") != std::string::npos) {
      throw ConfigError(Path(),
                        SafeText(text) + " is too close to 0 for a double (it would round to 0)");
    }
    return Add(json(value));
  }
  bool string(std::string& value) { return Add(json(std::move(value))); }
  bool binary(json::binary_t& value) { return Add(json::binary(std::move(value))); }
  bool start_object(std::size_t) { return Open(json::object()); }
  bool key(std::string& key) {
    levels_.back().key = std::move(key);
    return true;
  }
  bool end_object() { return Close(); }
  bool start_array(std::size_t) { return Open(json::array()); }
  bool end_array() { return Close(); }
  bool parse_error(std::size_t, const std::string& last_token, const json::exception& error) {
    if (error.id == 406) {  // out_of_range.406: a number beyond the range of a double
      throw ConfigError(Path(), SafeText(last_token) +
                                    " is out of the range of a double (at most 1.8e308 in "
                                    "magnitude)");
    }
    // "[json.exception.parse_error.101] parse error at line 1, column 9: ... last read: '...'":
    // the position comes before the token read, which a bound cuts first.
    throw ConfigError("", "malformed JSON: " + SafeText(error.what(), 400));
  }

  json Take() { return std::move(root_); }

 private:
  struct Level {
    json* container;
    std::string key;  // in an object: the key of the value being read
  };

  // The path of the value being read: "params.viscosity", "fluid_blocks[1].size[0]".
  std::string Path() const {
    std::string path;
    for (size_t i = 0; i < levels_.size(); ++i) {
      const json& container = *levels_[i].container;
      if (container.is_object()) {
        if (!path.empty()) path += '.';
        path += SafeText(levels_[i].key);
      } else {
        // A container being read is the last element of its parent; a value is the next one.
        const size_t index = container.size() - (i + 1 < levels_.size() ? 1 : 0);
        path += "[" + std::to_string(index) + "]";
      }
    }
    return path;
  }

  // Adds `value` where the parser is; returns where it now lives.
  json* Place(json&& value) {
    if (levels_.empty()) {
      root_ = std::move(value);
      return &root_;
    }
    Level& top = levels_.back();
    if (top.container->is_array()) {
      top.container->push_back(std::move(value));
      return &top.container->back();
    }
    json& slot = (*top.container)[top.key];  // a repeated key keeps the last value (json::parse)
    slot = std::move(value);
    return &slot;
  }
  bool Add(json&& value) {
    Place(std::move(value));
    return true;
  }
  // A container's parent is not touched until it closes, so the pointer stays valid.
  bool Open(json&& container) {
    if (levels_.size() >= kMaxSceneJsonDepth) {
      throw ConfigError(Path(), "nested deeper than " + std::to_string(kMaxSceneJsonDepth) +
                                    " levels of objects and arrays");
    }
    json* placed = Place(std::move(container));
    levels_.push_back({placed, ""});
    return true;
  }
  bool Close() {
    levels_.pop_back();
    return true;
  }

  json root_;
  std::vector<Level> levels_;
};

}  // namespace

json ParseSceneJson(std::string_view text) {
  PathTrackingBuilder builder;
  try {
    json::sax_parse(text.begin(), text.end(), &builder);
  } catch (const json::exception& e) {
    // The builder turns the parser's errors into ConfigErrors; this is for anything else.
    throw ConfigError("", "malformed JSON: " + SafeText(e.what(), 400));
  }
  return builder.Take();
}

}  // namespace dysa

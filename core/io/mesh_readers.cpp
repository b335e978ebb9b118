// The VTK XML UnstructuredGrid (.vtu) reader: ASCII, inline base64 and appended (raw or
// base64) data, uncompressed or zlib-compressed, little or big endian, UInt32 or UInt64
// headers, several pieces. Only VTK_TETRA cells are kept. Like every reader here it distrusts
// the file: sizes are checked against the bytes present before anything is allocated.
#include <zlib.h>  // linked through cvtcore's dependencies (ITK and CGAL_ImageIO use zlib)

#include <algorithm>
#include <array>
#include <cstring>
#include <map>
#include <optional>
#include <type_traits>

#include "base/errors.h"
#include "io/mesh_io.h"

namespace cvt::detail {
namespace {

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v';
}

// An integer held in a double (some tools store labels as floats), else nullopt.
std::optional<std::int64_t> integral(double d) {
  if (!(d >= -9.2e18 && d <= 9.2e18) || d != double(std::int64_t(d))) return std::nullopt;
  return std::int64_t(d);
}

// Converts `count` packed values of type S to T (double or int64); false when a value does
// not fit T.
template <typename T, typename S>
bool convert_values(const unsigned char* bytes, std::size_t count, bool swap, T* out) {
  for (std::size_t i = 0; i < count; ++i) {
    unsigned char v[sizeof(S)];
    std::memcpy(v, bytes + i * sizeof(S), sizeof(S));
    if (swap) std::reverse(v, v + sizeof(S));
    S s;
    std::memcpy(&s, v, sizeof(S));
    if constexpr (std::is_floating_point_v<T>) {
      out[i] = T(s);
    } else if constexpr (std::is_floating_point_v<S>) {
      const auto value = integral(double(s));
      if (!value) return false;
      out[i] = *value;
    } else {
      if constexpr (std::is_same_v<S, std::uint64_t>) {
        if (s > std::uint64_t(INT64_MAX)) return false;
      }
      out[i] = T(s);
    }
  }
  return true;
}

template <typename T>
struct VtkType {
  const char* name;
  std::size_t size;
  bool (*convert)(const unsigned char*, std::size_t, bool, T*);
};

template <typename T>
const VtkType<T>* find_vtk_type(const std::string& name) {
  static const VtkType<T> kTypes[] = {{"Int8", 1, convert_values<T, std::int8_t>},
                                      {"UInt8", 1, convert_values<T, std::uint8_t>},
                                      {"Int16", 2, convert_values<T, std::int16_t>},
                                      {"UInt16", 2, convert_values<T, std::uint16_t>},
                                      {"Int32", 4, convert_values<T, std::int32_t>},
                                      {"UInt32", 4, convert_values<T, std::uint32_t>},
                                      {"Int64", 8, convert_values<T, std::int64_t>},
                                      {"UInt64", 8, convert_values<T, std::uint64_t>},
                                      {"Float32", 4, convert_values<T, float>},
                                      {"Float64", 8, convert_values<T, double>}};
  for (const VtkType<T>& type : kTypes) {
    if (name == type.name) return &type;
  }
  return nullptr;
}

struct XmlElement {
  std::string name, parent;
  std::map<std::string, std::string> attributes;
  std::string_view text;  // content up to the next tag (DataArray values)
  int piece = -1;         // index of the enclosing Piece
  std::string attribute(const std::string& key, const std::string& fallback = "") const {
    const auto it = attributes.find(key);
    return it == attributes.end() ? fallback : it->second;
  }
};

std::string xml_unescaped(std::string_view s) {
  std::string r(s);
  // &amp; last, so that "&amp;lt;" becomes "&lt;", not "<".
  for (const auto& [entity, c] :
       {std::pair{"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}, {"&amp;", '&'}}) {
    for (std::size_t at; (at = r.find(entity)) != std::string::npos;)
      r.replace(at, std::strlen(entity), 1, c);
  }
  return r;
}

// The small XML subset VTK writes: elements with quoted attributes, text, comments and
// processing instructions. `pos` is just after '<'; returns the element and whether it
// closes itself, leaving `pos` after '>'.
std::optional<std::pair<XmlElement, bool>> parse_start_tag(std::string_view xml, std::size_t& pos) {
  XmlElement e;
  std::size_t i = pos;
  while (i < xml.size() && !is_space(xml[i]) && xml[i] != '>' && xml[i] != '/') ++i;
  e.name = std::string(xml.substr(pos, i - pos));
  if (e.name.empty()) return std::nullopt;
  for (;;) {
    while (i < xml.size() && is_space(xml[i])) ++i;
    if (i >= xml.size()) return std::nullopt;
    if (xml[i] == '>' || (xml[i] == '/' && i + 1 < xml.size() && xml[i + 1] == '>')) {
      const bool self_closing = xml[i] == '/';
      pos = i + (self_closing ? 2 : 1);
      return std::make_pair(std::move(e), self_closing);
    }
    const std::size_t name_start = i;
    while (i < xml.size() && xml[i] != '=' && !is_space(xml[i]) && xml[i] != '>') ++i;
    const std::string key(xml.substr(name_start, i - name_start));
    while (i < xml.size() && is_space(xml[i])) ++i;
    if (i >= xml.size() || xml[i] != '=') return std::nullopt;
    ++i;
    while (i < xml.size() && is_space(xml[i])) ++i;
    if (i >= xml.size() || (xml[i] != '"' && xml[i] != '\'')) return std::nullopt;
    const std::size_t close = xml.find(xml[i], i + 1);
    if (close == std::string_view::npos) return std::nullopt;
    e.attributes[key] = xml_unescaped(xml.substr(i + 1, close - i - 1));
    i = close + 1;
  }
}

struct VtuDocument {
  XmlElement root;
  std::vector<XmlElement> pieces, arrays;
  std::optional<XmlElement> appended;
  std::string_view appended_data;  // after the leading '_'
};

// Splits the file into its XML part and the appended data (which may be raw bytes, so the
// XML scan must stop before it).
VtuDocument parse_vtu_xml(const std::string& path, std::string_view text) {
  const auto fail = [&](const std::string& why) { throw InputError(path + ": " + why); };
  VtuDocument doc;
  if (text.find("<VTKFile") == std::string_view::npos)
    fail("not a VTK XML file (no VTKFile element)");
  std::size_t xml_end = text.find("<AppendedData");
  if (xml_end != std::string_view::npos) {
    std::size_t pos = xml_end + 1;
    auto tag = parse_start_tag(text, pos);
    if (!tag) fail("malformed AppendedData tag");
    doc.appended = std::move(tag->first);
    const std::size_t underscore = text.find('_', pos);
    if (underscore == std::string_view::npos) fail("AppendedData without the leading '_'");
    std::size_t end = text.rfind("</AppendedData>");
    if (end == std::string_view::npos || end < underscore)
      end = text.size();  // truncated: checked per array
    doc.appended_data = text.substr(underscore + 1, end - underscore - 1);
  } else {
    xml_end = text.size();
  }
  const std::string_view xml = text.substr(0, xml_end);
  std::vector<std::string> stack;
  std::size_t pos = 0;
  bool have_root = false;
  while ((pos = xml.find('<', pos)) != std::string_view::npos) {
    const std::string_view rest = xml.substr(pos);
    if (rest.starts_with("<?") || rest.starts_with("<!")) {
      const std::string_view close = rest.starts_with("<?")     ? "?>"
                                     : rest.starts_with("<!--") ? "-->"
                                                                : ">";
      const std::size_t end = xml.find(close, pos);
      if (end == std::string_view::npos)
        fail("malformed XML (unterminated comment or declaration)");
      pos = end + close.size();
    } else if (rest.starts_with("</")) {
      const std::size_t end = xml.find('>', pos);
      if (end == std::string_view::npos) fail("malformed XML (unterminated end tag)");
      std::string name(xml.substr(pos + 2, end - pos - 2));
      while (!name.empty() && is_space(name.back())) name.pop_back();
      if (stack.empty() || stack.back() != name) fail("malformed XML (unexpected </" + name + ">)");
      stack.pop_back();
      pos = end + 1;
    } else {
      ++pos;
      auto tag = parse_start_tag(xml, pos);
      if (!tag) fail("malformed XML tag (truncated file?)");
      auto& [element, self_closing] = *tag;
      element.parent = stack.empty() ? "" : stack.back();
      element.piece = int(doc.pieces.size()) - 1;
      if (element.name == "VTKFile") {
        doc.root = element;
        have_root = true;
      } else if (element.name == "Piece") {
        doc.pieces.push_back(element);
      } else if (element.name == "DataArray" && !self_closing) {
        // The values, beside child elements (VTK 9 adds InformationKey ones) if any.
        const std::size_t close = xml.find("</DataArray>", pos);
        if (close == std::string_view::npos) fail("DataArray without an end (truncated file?)");
        const std::string_view body = xml.substr(pos, close - pos);
        const std::size_t first = body.find('<'), last = body.rfind('>');
        element.text = body.substr(0, first);
        if (first != std::string_view::npos &&
            body.find_first_not_of(" \t\r\n", last + 1) != std::string_view::npos) {
          element.text = body.substr(last + 1);
        }
        doc.arrays.push_back(element);
        pos = close + std::string_view("</DataArray>").size();
        continue;
      }
      if (element.name == "DataArray") doc.arrays.push_back(element);
      if (!self_closing) stack.push_back(element.name);
    }
  }
  if (!have_root) fail("not a VTK XML file (no VTKFile element)");
  const std::string type = doc.root.attribute("type");
  if (type != "UnstructuredGrid") fail("not an UnstructuredGrid (VTKFile type '" + type + "')");
  if (doc.pieces.empty()) fail("no Piece in the UnstructuredGrid");
  return doc;
}

// Decodes base64, tolerating whitespace and '=' padding in the middle: VTK encodes a
// header and its data as two separately padded streams, meshio as one.
std::optional<std::vector<unsigned char>> base64_decoded(std::string_view s) {
  static const std::array<int, 256> kValue = [] {
    std::array<int, 256> value;
    value.fill(-1);
    const std::string_view alphabet =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (std::size_t i = 0; i < alphabet.size(); ++i) value[(unsigned char)alphabet[i]] = int(i);
    return value;
  }();
  std::vector<unsigned char> out;
  out.reserve(s.size() / 4 * 3);
  unsigned group = 0;
  int symbols = 0, padding = 0;
  for (char c : s) {
    if (is_space(c)) continue;
    const int v = c == '=' ? 0 : kValue[(unsigned char)c];
    if (v < 0 || (padding > 0 && c != '=')) return std::nullopt;
    padding += c == '=';
    group = group << 6 | unsigned(v);
    if (++symbols == 4) {
      if (padding > 2) return std::nullopt;
      for (int i = 0; i < 3 - padding; ++i) out.push_back((group >> (16 - 8 * i)) & 0xff);
      group = 0, symbols = 0, padding = 0;
    }
  }
  if (symbols != 0) return std::nullopt;
  return out;
}

// Reads DataArray values as T (double or int64), whatever their stored form.
class VtuArrays {
 public:
  VtuArrays(const std::string& path, const VtuDocument& doc) : path_(path), doc_(doc) {
    big_endian_ = doc.root.attribute("byte_order", "LittleEndian") == "BigEndian";
    const std::string header_type = doc.root.attribute("header_type", "UInt32");
    if (header_type != "UInt32" && header_type != "UInt64") {
      fail("", "unsupported header_type " + header_type);
    }
    header_size_ = header_type == "UInt32" ? 4 : 8;
    const std::string compressor = doc.root.attribute("compressor");
    if (!compressor.empty() && compressor != "vtkZLibDataCompressor") {
      fail("", "unsupported compressor " + compressor + " (only vtkZLibDataCompressor)");
    }
    zlib_ = !compressor.empty();
    for (const XmlElement& a : doc.arrays) {
      if (a.attribute("format") == "appended") offsets_.push_back(offset_of(a));
    }
    std::sort(offsets_.begin(), offsets_.end());
  }

  // Exactly `expected` values, or an InputError.
  template <typename T>
  std::vector<T> values(const XmlElement& a, std::size_t expected) const {
    const std::string format = a.attribute("format", "ascii");
    const VtkType<T>* type = find_vtk_type<T>(a.attribute("type"));
    if (!type) fail(a, "unsupported type '" + a.attribute("type") + "'");
    if (format == "ascii") return ascii_values<T>(a, expected);
    if (format != "binary" && format != "appended") fail(a, "unknown format '" + format + "'");
    if (expected > SIZE_MAX / type->size) fail(a, "count too large");
    const std::vector<unsigned char> bytes = payload(a, expected * type->size);
    std::vector<T> result(expected);
    if (!type->convert(bytes.data(), expected, big_endian_, result.data())) {
      fail(a, "expected integers in range");
    }
    return result;
  }

  [[noreturn]] void fail(const XmlElement& a, const std::string& why) const {
    fail(a.attribute("Name"), why);
  }
  [[noreturn]] void fail(const std::string& name, const std::string& why) const {
    throw InputError(path_ + ": " + (name.empty() ? "" : "DataArray '" + name + "': ") + why);
  }

 private:
  std::size_t offset_of(const XmlElement& a) const {
    const auto offset = parse_int(a.attribute("offset"));
    if (!offset || *offset < 0 || std::size_t(*offset) > doc_.appended_data.size()) {
      fail(a, "bad or missing appended offset");
    }
    return std::size_t(*offset);
  }

  template <typename T>
  std::vector<T> ascii_values(const XmlElement& a, std::size_t expected) const {
    std::vector<T> result;  // grows with the values present, whatever `expected` claims
    std::string_view text = a.text;
    for (;;) {
      std::size_t start = 0;
      while (start < text.size() && is_space(text[start])) ++start;
      if (start == text.size()) break;
      std::size_t end = start;
      while (end < text.size() && !is_space(text[end])) ++end;
      const std::string_view token = text.substr(start, end - start);
      text.remove_prefix(end);
      std::optional<T> value;
      if constexpr (std::is_floating_point_v<T>) {
        value = parse_double(token);
      } else {
        value = parse_int(token);
        if (const auto d = value ? std::nullopt : parse_double(token)) value = integral(*d);
      }
      if (!value) fail(a, "bad number '" + std::string(token.substr(0, 40)) + "'");
      if (result.size() == expected) {
        fail(a, "more values than the expected " + std::to_string(expected));
      }
      result.push_back(*value);
    }
    if (result.size() != expected) {
      fail(a, std::to_string(result.size()) + " values, expected " + std::to_string(expected));
    }
    return result;
  }

  // The array's bytes (after the header), decoded and decompressed; must be `expected` long.
  std::vector<unsigned char> payload(const XmlElement& a, std::size_t expected) const {
    std::vector<unsigned char> decoded;
    std::string_view raw;
    const bool appended = a.attribute("format") == "appended";
    const bool raw_encoding =
        appended && doc_.appended && doc_.appended->attribute("encoding") == "raw";
    if (appended && !doc_.appended) fail(a, "format 'appended' but no AppendedData");
    if (raw_encoding) {
      raw = doc_.appended_data.substr(offset_of(a));
    } else {
      std::string_view encoded = a.text;
      if (appended) {
        const std::size_t offset = offset_of(a);
        const auto next = std::upper_bound(offsets_.begin(), offsets_.end(), offset);
        encoded = doc_.appended_data.substr(
            offset, (next == offsets_.end() ? doc_.appended_data.size() : *next) - offset);
      }
      auto bytes = base64_decoded(encoded);
      if (!bytes) fail(a, "invalid base64 data");
      decoded = std::move(*bytes);
      raw = std::string_view(reinterpret_cast<const char*>(decoded.data()), decoded.size());
    }
    const auto header = [&](std::size_t i) {
      if ((i + 1) * header_size_ > raw.size()) fail(a, "data truncated (header)");
      unsigned char v[8];
      std::memcpy(v, raw.data() + i * header_size_, header_size_);
      if (big_endian_) std::reverse(v, v + header_size_);
      std::uint64_t value = 0;
      for (std::size_t b = header_size_; b-- > 0;) value = value << 8 | v[b];
      return value;
    };
    const auto* data = reinterpret_cast<const unsigned char*>(raw.data());
    if (!zlib_) {
      const std::uint64_t size = header(0);
      if (size != expected)
        fail(a, std::to_string(size) + " bytes, expected " + std::to_string(expected));
      if (size > raw.size() - header_size_) fail(a, "data truncated");
      return std::vector<unsigned char>(data + header_size_, data + header_size_ + size);
    }
    // zlib: [#blocks, block size, last block size, compressed sizes...], then the blocks.
    const std::uint64_t blocks = header(0), block_size = header(1), last_size = header(2);
    if (blocks > raw.size() / header_size_) fail(a, "data truncated (block table)");
    // Every block but the last holds block_size bytes; a short last one says so. Checked
    // piece by piece so that no product or sum can overflow.
    const std::uint64_t last = last_size ? last_size : block_size;
    if (blocks > 0 &&
        (last > expected || (blocks > 1 && block_size > (expected - last) / (blocks - 1)) ||
         (blocks - 1) * block_size + last != expected)) {
      fail(a,
           "compressed sizes do not add up to the expected " + std::to_string(expected) + " bytes");
    }
    if (blocks == 0 && expected != 0)
      fail(a, "no data, expected " + std::to_string(expected) + " bytes");
    std::size_t at = (3 + blocks) * header_size_;
    std::vector<unsigned char> out;
    for (std::uint64_t b = 0; b < blocks; ++b) {
      const std::uint64_t compressed = header(3 + b);
      if (at > raw.size() || compressed > raw.size() - at)
        fail(a, "data truncated (compressed block)");
      const std::uint64_t want = b + 1 == blocks ? last : block_size;
      inflate_block(a, data + at, std::size_t(compressed), std::size_t(want), out);
      at += compressed;
    }
    return out;
  }

  // Inflates into `out` in chunks, so memory follows the real output, not a claimed size.
  void inflate_block(const XmlElement& a, const unsigned char* in, std::size_t size,
                     std::size_t want, std::vector<unsigned char>& out) const {
    if (size > UINT32_MAX) fail(a, "compressed block too large");
    z_stream z{};
    if (inflateInit(&z) != Z_OK) fail(a, "zlib initialisation failed");
    z.next_in = const_cast<unsigned char*>(in);
    z.avail_in = uInt(size);
    const std::size_t start = out.size();
    unsigned char chunk[1 << 16];
    int status = Z_OK;
    while (status != Z_STREAM_END) {
      z.next_out = chunk;
      z.avail_out = sizeof chunk;
      status = inflate(&z, Z_NO_FLUSH);
      const std::size_t produced = sizeof chunk - z.avail_out;
      if ((status != Z_OK && status != Z_STREAM_END) || (status == Z_OK && produced == 0) ||
          out.size() - start + produced > want) {
        inflateEnd(&z);
        fail(a, "corrupt compressed data");
      }
      out.insert(out.end(), chunk, chunk + produced);
    }
    inflateEnd(&z);
    if (out.size() - start != want) fail(a, "compressed block has the wrong size");
  }

  const std::string& path_;
  const VtuDocument& doc_;
  bool big_endian_ = false, zlib_ = false;
  std::size_t header_size_ = 4;
  std::vector<std::size_t> offsets_;
};

std::size_t count_attribute(const std::string& path, const XmlElement& piece, const char* key) {
  const std::string text = piece.attribute(key);
  const auto n = parse_int(text);
  if (!n || *n < 0 || *n > INT32_MAX) {
    throw InputError(path + ": Piece " + key + "='" + text.substr(0, 40) +
                     "' is not a count up to 2^31");
  }
  return std::size_t(*n);
}

}  // namespace

TetMesh read_vtu(const std::string& path, std::string_view text) {
  const VtuDocument doc = parse_vtu_xml(path, text);
  VtuArrays arrays(path, doc);
  TetMesh mesh;
  bool any_labels = false;
  std::vector<std::int32_t> labels;
  for (int p = 0; p < int(doc.pieces.size()); ++p) {
    const std::size_t num_points = count_attribute(path, doc.pieces[p], "NumberOfPoints");
    const std::size_t num_cells = count_attribute(path, doc.pieces[p], "NumberOfCells");
    const auto find = [&](const char* parent, const std::string& name) -> const XmlElement* {
      for (const XmlElement& a : doc.arrays) {
        if (a.piece == p && a.parent == parent && (name.empty() || a.attribute("Name") == name))
          return &a;
      }
      return nullptr;
    };
    const XmlElement* points = find("Points", "");
    if (!points) throw InputError(path + ": Piece " + std::to_string(p) + " has no Points");
    if (points->attribute("NumberOfComponents", "1") != "3")
      arrays.fail(*points, "points need 3 components");
    const std::vector<double> xyz = arrays.values<double>(*points, 3 * num_points);
    const std::size_t first_vertex = mesh.vertices.size();
    for (std::size_t i = 0; i < num_points; ++i)
      mesh.vertices.push_back({xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]});
    if (num_cells == 0) continue;

    const XmlElement *connectivity = find("Cells", "connectivity"),
                     *offsets = find("Cells", "offsets"), *types = find("Cells", "types");
    if (!connectivity || !offsets || !types)
      throw InputError(path + ": Cells need connectivity, offsets and types");
    const std::vector<std::int64_t> ends = arrays.values<std::int64_t>(*offsets, num_cells);
    const std::vector<std::int64_t> kinds = arrays.values<std::int64_t>(*types, num_cells);
    for (std::size_t c = 0; c < num_cells; ++c) {
      if (ends[c] < (c ? ends[c - 1] : 0)) arrays.fail(*offsets, "offsets decrease");
    }
    const std::vector<std::int64_t> corners =
        arrays.values<std::int64_t>(*connectivity, std::size_t(ends.back()));
    std::optional<std::vector<std::int64_t>> refs;
    for (const char* name : {"label", "labels", "medit:ref", "gmsh:physical", "CellEntityIds",
                             "MaterialIds", "subdomain"}) {
      if (const XmlElement* a = find("CellData", name); a && !refs)
        refs = arrays.values<std::int64_t>(*a, num_cells);
    }
    constexpr std::int64_t kVtkTetra = 10;
    for (std::size_t c = 0; c < num_cells; ++c) {
      if (kinds[c] != kVtkTetra) continue;
      const std::int64_t begin = c ? ends[c - 1] : 0;
      if (ends[c] - begin != 4)
        arrays.fail(*offsets, "a tetra cell with " + std::to_string(ends[c] - begin) + " points");
      Tet tet;
      for (int k = 0; k < 4; ++k) {
        const std::int64_t v = corners[std::size_t(begin + k)];
        if (v < 0 || std::size_t(v) >= num_points) {
          arrays.fail(*connectivity, "point index " + std::to_string(v) + " out of range (" +
                                         std::to_string(num_points) + " points)");
        }
        tet[k] = std::int32_t(first_vertex + std::size_t(v));
      }
      mesh.tets.push_back(tet);
      const std::int64_t label = refs ? (*refs)[c] : 1;
      if (label < INT32_MIN || label > INT32_MAX)
        throw InputError(path + ": cell label out of range");
      labels.push_back(std::int32_t(label));
      any_labels = any_labels || refs.has_value();
    }
  }
  if (any_labels) mesh.labels = std::move(labels);
  return mesh;
}

}  // namespace cvt::detail

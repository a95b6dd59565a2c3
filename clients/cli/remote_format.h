// What the network verbs print: numbers, sizes, tables, field names and JSON with the proto's
// field names. Shared by the verbs' files (remote_*.cc); not part of their interface.
#pragma once

#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "dysa/client/types.h"

namespace dysa::remote {

using Json = nlohmann::ordered_json;  // keys in the order written, as in the proto

// `decimals` digits after the point ("0.2000").
std::string Fixed(double value, int decimals);
// Six significant digits, as a parameter is usually written ("0.001", "28.8", "1e+06").
std::string Short(double value);
// "950 B", "1.5 kB", "52.4 MB" (powers of 1000).
std::string HumanBytes(double bytes);
// Where the server's simulation steps: "cpu", or the GPU and the memory the simulation holds on
// it ("cuda:0 NVIDIA H200, 139.8 GiB, sm_90; 52.4 MB held").
std::string DeviceText(const ServerStatus& s);
// "frame 12 (t = 0.2000 s, step 36)"
std::string Where(const ServerStatus& s);
// dysa::codec::Field bits as names: "positions, speed".
std::string FieldNames(uint32_t fields);

// Rows of cells printed as columns, each as wide as its widest cell; `right` columns are
// right-aligned (numbers).
void PrintTable(const std::vector<std::vector<std::string>>& rows, const std::set<size_t>& right,
                std::ostream& out);

Json ToJson(const ServerStatus& s);
Json ToJson(const ControlResult& r);
// Indented by two, one object per call.
void PrintJson(const Json& json, std::ostream& out);

}  // namespace dysa::remote

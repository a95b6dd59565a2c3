// Tests of dysa/core/params.h: every declared parameter is checked against its range, and errors
// name the parameter and its range without changing anything.
#include "dysa/core/params.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "dysa/core/solver.h"
#include "dysa/core/text.h"
#include "dysa/core/types.h"

namespace dysa {
namespace {

using ::testing::HasSubstr;

// Every parameter value, in table order, so "unchanged" can be checked for all of them.
std::vector<double> AllValues(const Params& p) {
  std::vector<double> values;
  for (const ParamDecl& decl : ParamTable()) values.push_back(decl.get(p));
  return values;
}

// A parameter set with every value different from the defaults (and in range), so a write of
// a default value would also be noticed.
Params NonDefaultParams() {
  Params p;
  for (const ParamDecl& decl : ParamTable()) {
    double v = decl.min + 0.25 * (decl.max - decl.min);
    if (decl.integer) v = std::floor(v);
    if (v == decl.DefaultValue()) v = decl.integer ? v + 1 : 0.5 * (v + decl.max);
    decl.set(p, v);
  }
  return p;
}

// Expects SetParam(name, value) to throw a ConfigError naming the parameter and its range, and
// to leave the parameters unchanged.
void ExpectRejected(const ParamDecl& decl, double value) {
  SCOPED_TRACE(std::string(decl.name) + " = " + std::to_string(value));
  Params p = NonDefaultParams();
  const std::vector<double> before = AllValues(p);
  try {
    SetParam(p, decl.name, value);
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), decl.name);
    EXPECT_THAT(e.what(), HasSubstr(std::string(decl.name)));
    EXPECT_THAT(e.what(), HasSubstr(decl.RangeText()));
    EXPECT_THAT(e.message(), HasSubstr(decl.RangeText()));
  }
  EXPECT_EQ(AllValues(p), before);
}

TEST(ParamTableTest, HasUniqueNamesThatFindParamFinds) {
  ASSERT_FALSE(ParamTable().empty());
  std::set<std::string> names;
  for (const ParamDecl& decl : ParamTable()) {
    EXPECT_TRUE(names.insert(std::string(decl.name)).second) << "duplicate " << decl.name;
    EXPECT_EQ(FindParam(decl.name), &decl);
    EXPECT_FALSE(decl.description.empty()) << decl.name;
    EXPECT_LT(decl.min, decl.max) << decl.name;
  }
  EXPECT_EQ(FindParam("no_such_parameter"), nullptr);
  EXPECT_EQ(FindParam(""), nullptr);
}

TEST(ParamTableTest, DeclaresEveryThesisParameter) {
  // The thesis's control panel (DESIGN.md, Viewer): every slider has a parameter.
  for (const char* name :
       {"time_scale", "iterations_per_frame", "gravity", "collision_damping", "smoothing_radius",
        "target_density", "pressure_multiplier", "near_pressure_multiplier", "viscosity",
        "particle_quantity", "spawn_size", "spawn_jitter"}) {
    EXPECT_NE(FindParam(name), nullptr) << name;
  }
  EXPECT_TRUE(FindParam("particle_quantity")->integer);
  EXPECT_TRUE(FindParam("particle_quantity")->needs_reset);
  EXPECT_TRUE(FindParam("iterations_per_frame")->integer);
  EXPECT_FALSE(FindParam("viscosity")->needs_reset);
  EXPECT_FALSE(FindParam("gravity")->needs_reset);
}

TEST(ParamTableTest, DefaultsAreInRange) {
  for (const ParamDecl& decl : ParamTable()) {
    const double v = decl.DefaultValue();
    EXPECT_GE(v, decl.min) << decl.name;
    EXPECT_LE(v, decl.max) << decl.name;
    if (decl.integer) {
      EXPECT_EQ(v, std::floor(v)) << decl.name;
    }
    // The default passes the same validation as any other value.
    Params p;
    EXPECT_NO_THROW(SetParam(p, decl.name, v)) << decl.name;
  }
}

TEST(ParamTableTest, RangeTextShowsBoundsUnitAndIntegrality) {
  for (const ParamDecl& decl : ParamTable()) {
    const std::string text = decl.RangeText();
    EXPECT_EQ(text.front(), '[') << decl.name;
    EXPECT_THAT(text, HasSubstr(", ")) << decl.name;
    EXPECT_THAT(text, HasSubstr("]")) << decl.name;
    if (!decl.unit.empty()) {
      EXPECT_THAT(text, HasSubstr(std::string(decl.unit))) << decl.name;
    }
    EXPECT_EQ(text.find("integer") != std::string::npos, decl.integer) << decl.name << ": " << text;
  }
  EXPECT_EQ(FindParam("viscosity")->RangeText(), "[0, 10] m^3/s");
  EXPECT_EQ(FindParam("particle_quantity")->RangeText(), "[1, 500] (integer)");
}

TEST(SetParamTest, AcceptsTheBoundsOfEveryParameter) {
  for (const ParamDecl& decl : ParamTable()) {
    for (double v : {decl.min, decl.max}) {
      Params p = NonDefaultParams();
      std::vector<double> want = AllValues(p);
      EXPECT_NO_THROW(SetParam(p, decl.name, v)) << decl.name << " = " << v;
      EXPECT_EQ(GetParam(p, decl.name), v) << decl.name;
      EXPECT_EQ(decl.get(p), v) << decl.name;
      // Only this parameter changed.
      want[size_t(&decl - ParamTable().data())] = v;
      EXPECT_EQ(AllValues(p), want) << decl.name;
    }
  }
}

TEST(SetParamTest, RejectsValuesBelowTheMinimum) {
  for (const ParamDecl& decl : ParamTable()) {
    ExpectRejected(decl, std::nextafter(decl.min, -std::numeric_limits<double>::infinity()));
    ExpectRejected(decl, decl.min - 1);
    ExpectRejected(decl, -std::numeric_limits<double>::max());
  }
}

TEST(SetParamTest, RejectsValuesAboveTheMaximum) {
  for (const ParamDecl& decl : ParamTable()) {
    ExpectRejected(decl, std::nextafter(decl.max, std::numeric_limits<double>::infinity()));
    ExpectRejected(decl, decl.max + 1);
    ExpectRejected(decl, std::numeric_limits<double>::max());
  }
}

TEST(SetParamTest, RejectsNonFiniteValues) {
  for (const ParamDecl& decl : ParamTable()) {
    ExpectRejected(decl, std::numeric_limits<double>::quiet_NaN());
    ExpectRejected(decl, std::numeric_limits<double>::infinity());
    ExpectRejected(decl, -std::numeric_limits<double>::infinity());
  }
}

TEST(SetParamTest, RejectsNonIntegersForIntegerParameters) {
  int integer_params = 0;
  for (const ParamDecl& decl : ParamTable()) {
    if (!decl.integer) continue;
    ++integer_params;
    ExpectRejected(decl, decl.min + 0.5);
    ExpectRejected(decl, std::nextafter(decl.min + 1, 0.0));
    ExpectRejected(decl, decl.max - 0.25);
  }
  EXPECT_GE(integer_params, 2);
}

// The value in a message is the value refused, with every digit it needs: 2.0000000001 is not
// shown as 2, which would look allowed.
TEST(SetParamTest, MessagesShowTheValueRefusedAndWhy) {
  auto message = [](std::string_view name, double value) {
    Params p;
    try {
      SetParam(p, name, value);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no ConfigError");
  };
  EXPECT_EQ(message("iterations_per_frame", 2.0000000001),
            "iterations_per_frame: 2.0000000001 is not an integer; allowed range [1, 100] "
            "(integer)");
  EXPECT_EQ(message("viscosity", std::nextafter(10.0, 11.0)),
            "viscosity: 10.000000000000002 is outside the allowed range [0, 10] m^3/s");
  EXPECT_EQ(message("viscosity", -1e-300),
            "viscosity: -1e-300 is outside the allowed range [0, 10] m^3/s");
  EXPECT_EQ(message("viscosity", std::numeric_limits<double>::infinity()),
            "viscosity: inf is not a finite number; allowed range [0, 10] m^3/s");
  EXPECT_EQ(message("particle_quantity", 600),
            "particle_quantity: 600 is outside the allowed "
            "range [1, 500] (integer)");
}

TEST(SetParamTest, AnUnknownNameIsQuotedBoundedAndEscaped) {
  Params p;
  try {
    SetParam(p, std::string(3'900'000, 'x') + "\n", 1);
    FAIL() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_LE(e.field().size(), kMaxQuotedBytes);
    EXPECT_THAT(e.field(), HasSubstr("(3900001 bytes)"));
    EXPECT_LT(std::string(e.what()).size(), 2000u);
  }
  try {
    SetParam(p, "a\nb\x1b", 1);
    FAIL() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "a\\nb\\x1b");
  }
}

TEST(SetParamTest, UnknownNameThrowsNamingIt) {
  Params p = NonDefaultParams();
  const std::vector<double> before = AllValues(p);
  try {
    SetParam(p, "viscocity", 0.1);
    FAIL() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "viscocity");
    EXPECT_THAT(e.what(), HasSubstr("viscocity"));
    EXPECT_THAT(e.what(), HasSubstr("viscosity"));  // lists the known names
  }
  EXPECT_EQ(AllValues(p), before);
  EXPECT_THROW(GetParam(p, "nope"), ConfigError);
  EXPECT_THROW(SetParam(p, "", 1), ConfigError);
}

TEST(SetParamFromStringTest, SetsAGoodValue) {
  Params p;
  SetParamFromString(p, "viscosity=0.25");
  EXPECT_EQ(p.viscosity, 0.25);
  SetParamFromString(p, "gravity=-9.81");
  EXPECT_EQ(p.gravity, -9.81);
  SetParamFromString(p, "particle_quantity=12");
  EXPECT_EQ(p.particle_quantity, 12);
  SetParamFromString(p, "target_density=1e3");
  EXPECT_EQ(p.target_density, 1000.0);
}

// Expects SetParamFromString to throw a ConfigError whose field() is `field` and to leave the
// parameters unchanged; returns the message.
std::string ExpectFromStringRejected(std::string_view assignment, std::string_view field) {
  SCOPED_TRACE(std::string(assignment));
  Params p = NonDefaultParams();
  const std::vector<double> before = AllValues(p);
  std::string what;
  try {
    SetParamFromString(p, assignment);
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), field);
    what = e.what();
  }
  EXPECT_EQ(AllValues(p), before);
  return what;
}

TEST(SetParamFromStringTest, RejectsAMissingEqualsSign) {
  EXPECT_THAT(ExpectFromStringRejected("viscosity", "--set"), HasSubstr("NAME=VALUE"));
  ExpectFromStringRejected("viscosity 0.1", "--set");
  ExpectFromStringRejected("", "--set");
  ExpectFromStringRejected("=0.1", "--set");
}

TEST(SetParamFromStringTest, RejectsANonNumber) {
  const std::string range = FindParam("viscosity")->RangeText();
  EXPECT_THAT(ExpectFromStringRejected("viscosity=abc", "viscosity"), HasSubstr(range));
  EXPECT_THAT(ExpectFromStringRejected("viscosity=", "viscosity"), HasSubstr(range));
  ExpectFromStringRejected("viscosity= 0.1", "viscosity");
  ExpectFromStringRejected("viscosity=nan", "viscosity");
  ExpectFromStringRejected("viscosity=inf", "viscosity");
}

// A value a double cannot hold is not called "not a finite number": overflow and underflow
// say which they are.
TEST(SetParamFromStringTest, SaysWhyAValueIsNotADouble) {
  EXPECT_THAT(ExpectFromStringRejected("viscosity=abc", "viscosity"),
              HasSubstr("viscosity: 'abc' is not a number; allowed range [0, 10] m^3/s"));
  EXPECT_THAT(ExpectFromStringRejected("viscosity=1e999", "viscosity"),
              HasSubstr("'1e999' is out of the range of a double"));
  EXPECT_THAT(ExpectFromStringRejected("viscosity=-1e999", "viscosity"),
              HasSubstr("'-1e999' is out of the range of a double"));
  EXPECT_THAT(ExpectFromStringRejected("viscosity=1e-400", "viscosity"),
              HasSubstr("'1e-400' is too close to 0 for a double"));
  EXPECT_THAT(ExpectFromStringRejected("viscosity=inf", "viscosity"),
              HasSubstr("'inf' is not a finite number"));
  EXPECT_THAT(ExpectFromStringRejected("iterations_per_frame=2.0000000001", "iterations_per_frame"),
              HasSubstr("2.0000000001 is not an integer"));
  // A subnormal is a double: it is in range or not like any other value.
  EXPECT_THAT(ExpectFromStringRejected("viscosity=-1e-310", "viscosity"),
              HasSubstr("-1e-310 is outside the allowed range"));
}

TEST(ParseAssignmentTest, SplitsAndReadsWithoutLookingUpTheName) {
  EXPECT_EQ(ParseAssignment("viscosity=0.25"), std::make_pair(std::string("viscosity"), 0.25));
  EXPECT_EQ(ParseAssignment("from_a_newer_server=1e-3"),
            std::make_pair(std::string("from_a_newer_server"), 1e-3));
  auto field_and_message = [](std::string_view assignment) {
    try {
      ParseAssignment(assignment);
    } catch (const ConfigError& e) {
      return e.field() + " | " + e.message();
    }
    return std::string("no ConfigError");
  };
  EXPECT_EQ(field_and_message("viscosity"), " | expected NAME=VALUE, got 'viscosity'");
  EXPECT_EQ(field_and_message("=1"), " | expected NAME=VALUE, got '=1'");
  EXPECT_EQ(field_and_message("viscosity=1e-400"),
            "viscosity | '1e-400' is too close to 0 for a double (it would round to 0)");
  EXPECT_EQ(field_and_message("viscosity=1e400"),
            "viscosity | '1e400' is out of the range of a double (at most 1.8e308 in magnitude)");
  EXPECT_EQ(field_and_message("viscosity=nan"), "viscosity | 'nan' is not a finite number");
  EXPECT_EQ(field_and_message("viscosity=0.1x"), "viscosity | '0.1x' is not a number");
  EXPECT_EQ(field_and_message("a\x1b=\n"), "a\\x1b | '\\n' is not a number");
}

TEST(SetParamFromStringTest, RejectsTrailingGarbage) {
  ExpectFromStringRejected("viscosity=0.1x", "viscosity");
  ExpectFromStringRejected("viscosity=0.1 ", "viscosity");
  ExpectFromStringRejected("viscosity=0.1=0.2", "viscosity");
  ExpectFromStringRejected("particle_quantity=12,5", "particle_quantity");
}

TEST(SetParamFromStringTest, RejectsOutOfRangeNonIntegerAndUnknown) {
  const std::string range = FindParam("viscosity")->RangeText();
  EXPECT_THAT(ExpectFromStringRejected("viscosity=-1", "viscosity"), HasSubstr(range));
  ExpectFromStringRejected("particle_quantity=12.5", "particle_quantity");
  ExpectFromStringRejected("particle_quantity=0", "particle_quantity");
  ExpectFromStringRejected("viscocity=0.1", "viscocity");
}

TEST(ParamTableTest, EverySolverNameIsRegistered) {
  std::set<std::string> registered;
  for (const SolverInfo& info : SolverRegistry()) registered.insert(std::string(info.name));
  std::set<std::string> listed;  // solvers some parameter names
  for (const ParamDecl& decl : ParamTable()) {
    SCOPED_TRACE(std::string(decl.name));
    std::set<std::string> names;
    for (std::string_view solver : decl.solvers) {
      EXPECT_TRUE(registered.count(std::string(solver))) << "unknown solver " << solver;
      EXPECT_TRUE(names.insert(std::string(solver)).second) << "listed twice: " << solver;
      EXPECT_TRUE(decl.ReadBy(solver));
      listed.insert(std::string(solver));
    }
    // Every solver is spelt as the empty list ("all"), so a new solver is not left out.
    EXPECT_LT(names.size(), registered.size());
  }
  // Every solver has parameters of its own (the viewer shows them).
  EXPECT_EQ(listed, registered);
}

TEST(ParamTableTest, SolversTextNamesTheSolvers) {
  EXPECT_EQ(FindParam("time_scale")->SolversText(), "all");
  EXPECT_TRUE(FindParam("time_scale")->ReadBy("dfsph"));
  EXPECT_EQ(FindParam("viscosity")->SolversText(), "seed");
  EXPECT_FALSE(FindParam("viscosity")->ReadBy("dfsph"));
  EXPECT_EQ(FindParam("gravity_ramp_time")->SolversText(), "wcsph, dfsph");
  EXPECT_EQ(FindParam("speed_of_sound")->SolversText(), "wcsph");
  EXPECT_EQ(FindParam("warm_start")->SolversText(), "dfsph");
}

// The cells of a Markdown table row "| a | b | ... |", trimmed; the last `columns`-th cell
// keeps whatever follows (a description may hold a '|').
std::vector<std::string> TableCells(const std::string& line, size_t columns) {
  std::vector<std::string> cells;
  size_t begin = 1;  // after the leading '|'
  while (cells.size() + 1 < columns) {
    const size_t bar = line.find('|', begin);
    if (bar == std::string::npos) break;
    cells.push_back(line.substr(begin, bar - begin));
    begin = bar + 1;
  }
  std::string rest = line.substr(begin);
  if (!rest.empty() && rest.back() == '|') rest.pop_back();
  cells.push_back(rest);
  for (std::string& cell : cells) {
    cell.erase(0, cell.find_first_not_of(' '));
    cell.erase(cell.find_last_not_of(' ') + 1);
  }
  return cells;
}

double Number(const std::string& text) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  EXPECT_TRUE(!text.empty() && *end == '\0') << "not a number: '" << text << "'";
  return value;
}

// scenes/README.md's parameter table is the declarations': the same names in the same order,
// units, defaults, ranges, whether a change re-spawns and which solvers read each (the
// "Meaning" column may say more than the description).
TEST(ParamTableTest, ScenesReadmeTableMatchesTheDeclarations) {
  const std::string path = std::string(DYSA_SCENES_DIR) + "/README.md";
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  std::string line;
  while (std::getline(in, line) && line != "## Parameters") {
  }
  while (std::getline(in, line) && line.rfind("| Name |", 0) != 0) {
  }
  ASSERT_EQ(TableCells(line, 7), (std::vector<std::string>{"Name", "Unit", "Default", "Allowed",
                                                           "Re-spawns", "Read by", "Meaning"}))
      << path << ": no parameter table after \"## Parameters\"";
  std::getline(in, line);  // | --- | ...
  size_t row = 0;
  const std::span<const ParamDecl> table = ParamTable();
  while (std::getline(in, line) && line.rfind("|", 0) == 0) {
    const std::vector<std::string> cells = TableCells(line, 7);
    ASSERT_EQ(cells.size(), 7u) << line;
    ASSERT_LT(row, table.size()) << "a row for an undeclared parameter: " << line;
    const ParamDecl& decl = table[row++];
    SCOPED_TRACE(std::string(decl.name));
    EXPECT_EQ(cells[0], "`" + std::string(decl.name) + "`") << "declaration order";
    EXPECT_EQ(cells[1], decl.unit);
    EXPECT_EQ(Number(cells[2]), decl.DefaultValue()) << cells[2];
    // "[min, max]" or "[min, max], integer"
    const std::string integer_suffix = ", integer";
    std::string range = cells[3];
    const bool integer = range.size() > integer_suffix.size() && range.ends_with(integer_suffix);
    if (integer) range.erase(range.size() - integer_suffix.size());
    EXPECT_EQ(integer, decl.integer) << cells[3];
    const size_t comma = range.find(", ");
    ASSERT_TRUE(range.starts_with("[") && range.ends_with("]") && comma != std::string::npos)
        << cells[3];
    EXPECT_EQ(Number(range.substr(1, comma - 1)), decl.min) << cells[3];
    EXPECT_EQ(Number(range.substr(comma + 2, range.size() - comma - 3)), decl.max) << cells[3];
    EXPECT_EQ(cells[4], decl.needs_reset ? "yes" : "no");
    EXPECT_EQ(cells[5], decl.SolversText());
    EXPECT_FALSE(cells[6].empty());
  }
  EXPECT_EQ(row, table.size()) << "parameters missing from " << path;
}

}  // namespace
}  // namespace dysa

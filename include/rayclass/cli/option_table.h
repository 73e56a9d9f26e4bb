// A command's options as a table: each option's spellings, the name of its value, its help text
// and what it does with its value. The one table parses the arguments and prints the help, so
// the two cannot drift apart.
#pragma once

#include <charconv>
#include <cstddef>
#include <functional>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rayclass/core/error.h"
#include "rayclass/render/options.h"

namespace rayclass::cli {

struct Option {
    std::vector<std::string> names;  // spellings the help shows, e.g. {"-o", "--output"}
    std::string value;               // the value's name in the help ("FILE"); empty: a flag
    // Help text, lines separated by '\n'. Empty: the option shares the next option's row, as in
    // "--width W, --height H".
    std::string help;
    // What the option does with its value ("" for a flag); `option` is the spelling given.
    std::function<void(const std::string& option, const std::string& value)> apply;
    std::vector<std::string> hidden = {};  // spellings the help does not show (-h)
    bool ends = false;                     // the rest of the arguments go unread (--help)
};

class OptionTable {
  public:
    // `unknownHint` follows the message about an unknown option. A lone "-" is an operand when
    // `dashIsOperand`, else an unknown option.
    explicit OptionTable(std::vector<Option> options, std::string unknownHint = {},
                         bool dashIsOperand = false);

    // Applies the options of `args` in order and passes every other argument to `operand`.
    // Throws UsageError for an unknown option or a missing value.
    void Parse(const std::vector<std::string>& args,
               const std::function<void(const std::string&)>& operand) const;

    // One row per option (or per run of options sharing a row): two spaces, the spellings and
    // value padded to `column`, the help; continuation lines indented to the help.
    std::string Help(size_t column) const;

  private:
    const Option* Find(const std::string& arg) const;

    std::vector<Option> options_;
    std::string unknownHint_;
    bool dashIsOperand_;
};

// `text` as a number in [lo, hi], all of it, or a UsageError "OPTION expects WHAT in [lo, hi],
// not 'text'".
template <typename T>
T ParseNumber(const std::string& option, const std::string& text, T lo, T hi,
              std::string_view what = "a number") {
    T value{};
    const char* end = text.data() + text.size();
    auto [ptr, ec] = std::from_chars(text.data(), end, value);
    if (ec != std::errc() || ptr != end || !(value >= lo && value <= hi)) {
        std::ostringstream msg;
        msg << option << " expects " << what << " in [" << lo << ", " << hi << "], not '" << text
            << "'";
        throw UsageError(msg.str());
    }
    return value;
}

// An Option::apply that stores its value, a number in [lo, hi] (ParseNumber), in `field`.
template <typename T>
auto Number(T& field, T lo, T hi, std::string_view what = "a number") {
    return [&field, lo, hi, what](const std::string& option, const std::string& value) {
        field = ParseNumber<T>(option, value, lo, hi, what);
    };
}

// An Option::apply that stores its value as it is in `field`.
inline auto Text(std::string& field) {
    return [&field](const std::string&, const std::string& value) { field = value; };
}

// An Option::apply for a flag: sets `field` to `to`.
inline auto Flag(bool& field, bool to = true) {
    return [&field, to](const std::string&, const std::string&) { field = to; };
}

// "a, b or c" of the names in `names`.
template <typename E, size_t N>
std::string ChoiceList(const render::Named<E> (&names)[N]) {
    std::string list;
    for (size_t k = 0; k < N; ++k) {
        if (k > 0) list += k + 1 == N ? " or " : ", ";
        list += names[k].name;
    }
    return list;
}

// The value `name` names in `names`, or a UsageError "OPTION must be a, b or c, not 'name'".
template <typename E, size_t N>
E ParseChoice(const std::string& option, const std::string& name,
              const render::Named<E> (&names)[N]) {
    if (const auto value = render::FindChoice(names, name)) return *value;
    throw UsageError(option + " must be " + ChoiceList(names) + ", not '" + name + "'");
}

// An Option::apply that stores the choice its value names in `field` (a value or an optional).
template <typename Field, typename E, size_t N>
auto Choice(Field& field, const render::Named<E> (&names)[N]) {
    return [&field, &names](const std::string& option, const std::string& value) {
        field = ParseChoice(option, value, names);
    };
}

// NAME and VALUE of `text`, "NAME=VALUE", or a UsageError "OPTION expects NAME=VALUE".
std::pair<std::string, std::string> NameValue(const std::string& option, const std::string& text);

}  // namespace rayclass::cli

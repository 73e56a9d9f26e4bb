#include "rayclass/cli/option_table.h"

#include <algorithm>

namespace rayclass::cli {

namespace {

std::string Label(const Option& option) {
    std::string label;
    for (const std::string& name : option.names) label += (label.empty() ? "" : ", ") + name;
    return option.value.empty() ? label : label + " " + option.value;
}

}  // namespace

OptionTable::OptionTable(std::vector<Option> options, std::string unknownHint, bool dashIsOperand)
    : options_(std::move(options)),
      unknownHint_(std::move(unknownHint)),
      dashIsOperand_(dashIsOperand) {}

const Option* OptionTable::Find(const std::string& arg) const {
    for (const Option& option : options_) {
        if (std::ranges::count(option.names, arg) || std::ranges::count(option.hidden, arg)) {
            return &option;
        }
    }
    return nullptr;
}

void OptionTable::Parse(const std::vector<std::string>& args,
                        const std::function<void(const std::string&)>& operand) const {
    for (size_t i = 0; i < args.size(); ++i) {
        const std::string& arg = args[i];
        const bool optionLike = arg.size() > 1 ? arg[0] == '-' : arg == "-" && !dashIsOperand_;
        if (!optionLike) {
            operand(arg);
            continue;
        }
        const Option* option = Find(arg);
        if (!option) throw UsageError("unknown option '" + arg + "'" + unknownHint_);
        if (!option->value.empty() && i + 1 >= args.size()) {
            throw UsageError(arg + " needs a value");
        }
        option->apply(arg, option->value.empty() ? std::string() : args[++i]);
        if (option->ends) return;
    }
}

std::string OptionTable::Help(size_t column) const {
    std::string text, label;
    for (const Option& option : options_) {
        label += (label.empty() ? "" : ", ") + Label(option);
        if (option.help.empty()) continue;
        label.resize(std::max(column, label.size() + 1), ' ');
        text += "  " + label;
        for (const char c : option.help) {
            text += c;
            if (c == '\n') text += std::string(column + 2, ' ');
        }
        text += "\n";
        label.clear();
    }
    return text;
}

std::pair<std::string, std::string> NameValue(const std::string& option, const std::string& text) {
    const auto eq = text.find('=');
    if (eq == std::string::npos) {
        throw UsageError(option + " expects NAME=VALUE, not '" + text + "'");
    }
    return {text.substr(0, eq), text.substr(eq + 1)};
}

}  // namespace rayclass::cli

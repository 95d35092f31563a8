#pragma once
// The exit codes of pgi and pgi_peers (README "Limits and exit codes"), from the exception that ended
// the program: the one place exception types become codes.
#include "tools/atomic_file.hpp"
#include "tools/commands.hpp"

#include <new>
#include <string>

namespace pgi {

/// Call inside a catch block: says "PROGRAM: message" on stderr (say) (where names the scene when the
/// message does not) and returns the code of the exception being handled.
inline int exit_code_of_current_exception(const std::string& program, const std::string& where) {
    const std::string at = program + ": " + (where.empty() ? "" : where + ": ");
    try {
        throw;
    } catch (const NumericalFailure& e) {
        say(at + e.what());
        return 3;
    } catch (const SceneError& e) {
        say(program + ": " + e.what());
        return 2;
    } catch (const BudgetError& e) {
        say(program + ": " + e.what());
        return 4;
    } catch (const ResourceLimitError& e) {
        say(at + "exact phase stopped: " + e.what());
        return 4;
    } catch (const OutputError& e) {
        say(program + ": " + e.what());
        return 6;
    } catch (const NativeCodeError& e) {
        say(at + e.what());
        return 7;
    } catch (const std::bad_alloc&) {
        say(at + "out of memory (an allocation failed within the budget; lower --max-terms)");
        return 5;
    } catch (const std::invalid_argument& e) {
        say(at + e.what());
        return 2;
    } catch (const std::exception& e) {
        say(program + ": internal error: " + e.what());
        return 1;
    } catch (...) {
        say(program + ": internal error: unknown exception");
        return 1;
    }
}

}  // namespace pgi

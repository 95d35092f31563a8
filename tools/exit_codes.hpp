#pragma once
// The exit codes of pgi and pgi_peers (README "Limits and exit codes"), from the exception that ended
// the program: the one place exception types become codes.
#include "tools/atomic_file.hpp"
#include "tools/commands.hpp"

#include <iostream>
#include <new>
#include <string>

namespace pgi {

/// Call inside a catch block: prints "PROGRAM: message" on stderr (where names the scene when the
/// message does not) and returns the code of the exception being handled.
inline int exit_code_of_current_exception(const std::string& program, const std::string& where) {
    const std::string at = program + ": " + (where.empty() ? "" : where + ": ");
    try {
        throw;
    } catch (const NumericalFailure& e) {
        std::cerr << at << e.what() << "\n";
        return 3;
    } catch (const SceneError& e) {
        std::cerr << program << ": " << e.what() << "\n";
        return 2;
    } catch (const BudgetError& e) {
        std::cerr << program << ": " << e.what() << "\n";
        return 4;
    } catch (const ResourceLimitError& e) {
        std::cerr << at << "exact phase stopped: " << e.what() << "\n";
        return 4;
    } catch (const OutputError& e) {
        std::cerr << program << ": " << e.what() << "\n";
        return 6;
    } catch (const NativeCodeError& e) {
        std::cerr << at << e.what() << "\n";
        return 7;
    } catch (const std::bad_alloc&) {
        std::cerr << at << "out of memory (an allocation failed within the budget; lower --max-terms)\n";
        return 5;
    } catch (const std::invalid_argument& e) {
        std::cerr << at << printable(e.what()) << "\n";
        return 2;
    } catch (const std::exception& e) {
        std::cerr << program << ": internal error: " << e.what() << "\n";
        return 1;
    } catch (...) {
        std::cerr << program << ": internal error: unknown exception\n";
        return 1;
    }
}

}  // namespace pgi

#include "scheme/version.hpp"

namespace pgi {

std::string_view version() {
    return PGI_VERSION;
}

}  // namespace pgi

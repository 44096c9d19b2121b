// Finds and loads libnfdecode_vdb (vdb_module.h) on the first VDB write.
#include <dlfcn.h>
#include <unistd.h>

#include <cstdlib>
#include <string>

#include "vdb_module.h"

namespace nfd {

namespace {

// The folder of the file this code was loaded from: the shared library, or the executable a static
// libnfdecode is linked into (for which dladdr may give argv[0], without a folder: then the
// kernel's /proc/self/exe). Empty when neither says.
std::string binary_directory() {
    std::string file;
    Dl_info info;
    if (dladdr(reinterpret_cast<void*>(&vdb_module_entry), &info) && info.dli_fname)
        file = info.dli_fname;
    if (file.find('/') == std::string::npos) {
        char exe[4096];
        const ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
        file = n > 0 ? std::string(exe, size_t(n)) : std::string();
    }
    const size_t slash = file.rfind('/');
    return slash == std::string::npos ? std::string() : file.substr(0, slash);
}

void* open_module() {
    const std::string name = NFD_VDB_MODULE_NAME;
    if (const char* path = std::getenv("NFD_VDB_MODULE"); path && *path)
        return dlopen(path, RTLD_NOW | RTLD_LOCAL);
    const std::string here = binary_directory();
    const std::string candidates[] = {
        here.empty() ? "" : here + "/" + name,
        here.empty() ? "" : here + "/../" NFD_INSTALL_LIBDIR "/" + name,
        NFD_INSTALL_FULL_LIBDIR "/" + name,
        name,
    };
    for (const std::string& path : candidates)
        if (!path.empty())
            if (void* module = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL)) return module;
    return nullptr;
}

}  // namespace

VdbWriteEntry vdb_module_entry() {
    // Loaded once and never closed: OpenVDB registers types and keeps statics for the process.
    static const VdbWriteEntry entry = [] {
        void* module = open_module();
        return module ? reinterpret_cast<VdbWriteEntry>(dlsym(module, kVdbEntry)) : nullptr;
    }();
    return entry;
}

}  // namespace nfd

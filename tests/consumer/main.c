/* Links and calls libnfdecode from C99 through the installed package. With arguments IN.nfc
 * OUT.vdb it also writes the asset's grid as OpenVDB through the installed writer module
 * (libnfdecode_vdb, loaded on that call). */
#include <nfdecode/nfdecode.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int fail(const char* what, nfd_result r) {
    fprintf(stderr, "consumer: %s: %s\n", what, nfd_result_string(r));
    return 1;
}

/* The whole file at path, or NULL. */
static unsigned char* read_all(const char* path, size_t* size) {
    FILE* f = fopen(path, "rb");
    unsigned char* bytes = NULL;
    long n;
    if (!f) return NULL;
    if (fseek(f, 0, SEEK_END) == 0 && (n = ftell(f)) > 0 && fseek(f, 0, SEEK_SET) == 0 &&
        (bytes = malloc((size_t)n)) != NULL && fread(bytes, 1, (size_t)n, f) != (size_t)n) {
        free(bytes);
        bytes = NULL;
    }
    *size = bytes ? (size_t)n : 0;
    fclose(f);
    return bytes;
}

static int write_vdb(nfd_context* context, const char* in, const char* out) {
    size_t size = 0;
    unsigned char* bytes = read_all(in, &size);
    nfd_asset* asset = NULL;
    nfd_grid* grid = NULL;
    nfd_grid_options options;
    nfd_result r;
    if (!bytes) {
        fprintf(stderr, "consumer: cannot read %s\n", in);
        return 1;
    }
    r = nfd_asset_create(bytes, size, &asset);
    free(bytes);
    if (r != NFD_SUCCESS) return fail("asset", r);
    memset(&options, 0, sizeof options);
    options.struct_size = sizeof options;
    options.resolution = 32;
    r = nfd_grid_extract(context, asset, &options, &grid);
    if (r == NFD_SUCCESS) r = nfd_grid_write_vdb(grid, out, in);
    nfd_grid_destroy(grid);
    nfd_asset_destroy(asset);
    if (r != NFD_SUCCESS) return fail("grid written as OpenVDB", r);
    printf("consumer: wrote %s\n", out);
    return 0;
}

int main(int argc, char** argv) {
    nfd_context_options options;
    nfd_context* context = NULL;
    nfd_asset* asset = NULL;
    const unsigned char not_nfc[32] = {0x89, 'N', 'F', 'X'};
    nfd_result r;
    int status = 0;

    memset(&options, 0, sizeof options); /* zero = defaults */
    options.struct_size = sizeof options;
    options.device = NFD_DEVICE_CPU;
    r = nfd_context_create(&options, &context);
    if (r != NFD_SUCCESS) return fail("context", r);
    r = nfd_asset_create(not_nfc, sizeof not_nfc, &asset);
    if (r != NFD_ERROR_CORRUPT || asset != NULL) {
        fprintf(stderr, "consumer: expected a corrupt-input error, got %s\n", nfd_result_string(r));
        return 1;
    }
    printf("consumer: libnfdecode %d.%d.%d on %s: %s\n", NFD_VERSION_MAJOR, NFD_VERSION_MINOR,
           NFD_VERSION_PATCH, nfd_context_device_name(context), nfd_result_string(r));
    if (argc == 3) status = write_vdb(context, argv[1], argv[2]);
    nfd_context_destroy(context);
    return status;
}

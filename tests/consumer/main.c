/* Links and calls libnfdecode from C99 through the installed package. */
#include <nfdecode/nfdecode.h>
#include <stdio.h>
#include <string.h>

int main(void) {
    nfd_context_options options;
    nfd_context* context = NULL;
    nfd_asset* asset = NULL;
    const unsigned char not_nfc[32] = {0x89, 'N', 'F', 'X'};
    nfd_result r;

    memset(&options, 0, sizeof options); /* zero = defaults */
    options.struct_size = sizeof options;
    options.device = NFD_DEVICE_CPU;
    r = nfd_context_create(&options, &context);
    if (r != NFD_SUCCESS) {
        fprintf(stderr, "consumer: context: %s\n", nfd_result_string(r));
        return 1;
    }
    r = nfd_asset_create(not_nfc, sizeof not_nfc, &asset);
    if (r != NFD_ERROR_CORRUPT || asset != NULL) {
        fprintf(stderr, "consumer: expected a corrupt-input error, got %s\n", nfd_result_string(r));
        return 1;
    }
    printf("consumer: libnfdecode %d.%d.%d on %s: %s\n", NFD_VERSION_MAJOR, NFD_VERSION_MINOR,
           NFD_VERSION_PATCH, nfd_context_device_name(context), nfd_result_string(r));
    nfd_context_destroy(context);
    return 0;
}

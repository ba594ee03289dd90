# brdftab_embed_kernels(<kernel dir> <output .cpp>)
#
# Generates, at build time, a C++ file holding every file under <kernel dir>
# (*.h, *.cl) as a string, keyed by its path relative to <kernel dir>.  The
# host resolves includes from this table (host/kernel_sources.cpp), so an
# installed brdftab needs no kernel files on disk.
function(brdftab_embed_kernels kernel_dir output)
  file(GLOB_RECURSE _kernel_files CONFIGURE_DEPENDS
       ${kernel_dir}/*.h ${kernel_dir}/*.cl)
  add_custom_command(
    OUTPUT ${output}
    COMMAND ${CMAKE_COMMAND} -DKERNEL_DIR=${kernel_dir} -DOUTPUT=${output}
            -P ${CMAKE_CURRENT_FUNCTION_LIST_DIR}/EmbedKernelsScript.cmake
    DEPENDS ${_kernel_files} ${CMAKE_CURRENT_FUNCTION_LIST_DIR}/EmbedKernelsScript.cmake
    COMMENT "Embedding OpenCL kernel sources"
    VERBATIM)
endfunction()

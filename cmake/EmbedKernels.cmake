# brdftab_embed_kernels(<kernel dir> <output .cpp> [ADDED])
#
# Generates, at build time, a C++ file holding every file under <kernel dir>
# (*.h, *.cl) as a string, keyed by its path relative to <kernel dir>.  The
# host resolves includes from this table (host/engine/kernel_sources.cpp), so
# an installed brdftab needs no kernel files on disk.  With ADDED the file
# instead adds its kernels to that table from a static initialiser
# (add_embedded_kernel_sources): for kernels kept outside kernels/, such as the
# test-only toy model in tests/toy_model/.
function(brdftab_embed_kernels kernel_dir output)
  set(_mode TABLE)
  if("ADDED" IN_LIST ARGN)
    set(_mode ADDED)
  endif()
  file(GLOB_RECURSE _kernel_files CONFIGURE_DEPENDS
       ${kernel_dir}/*.h ${kernel_dir}/*.cl)
  add_custom_command(
    OUTPUT ${output}
    COMMAND ${CMAKE_COMMAND} -DKERNEL_DIR=${kernel_dir} -DOUTPUT=${output} -DMODE=${_mode}
            -P ${CMAKE_CURRENT_FUNCTION_LIST_DIR}/EmbedKernelsScript.cmake
    DEPENDS ${_kernel_files} ${CMAKE_CURRENT_FUNCTION_LIST_DIR}/EmbedKernelsScript.cmake
    COMMENT "Embedding OpenCL kernel sources"
    VERBATIM)
endfunction()

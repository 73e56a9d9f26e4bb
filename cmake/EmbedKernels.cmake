# Writes a C++ source that maps each kernel file name to its text, so programs can be built
# without the source tree and build logs still name the real file.
function(rayclass_embed_kernels out)
  set(script ${CMAKE_BINARY_DIR}/generated/embed_kernels.cmake)
  # The file list goes into the script itself: a list on the command line would be split.
  file(WRITE ${script} "set(FILES \"${ARGN}\")\nset(OUT \"${out}\")\nset(ROOT \"${CMAKE_SOURCE_DIR}\")\n")
  file(APPEND ${script} [=[
set(body "// Generated from cl/ by cmake/EmbedKernels.cmake; do not edit.\n#include <map>\n#include <string>\nnamespace rayclass::clrt {\nconst std::map<std::string, std::string>& EmbeddedKernelSources() {\n    static const std::map<std::string, std::string> sources = {\n")
foreach(f ${FILES})
  file(READ ${f} text)
  file(RELATIVE_PATH rel ${ROOT}/cl ${f})
  string(APPEND body "        {\"${rel}\", R\"RCKERNEL(${text})RCKERNEL\"},\n")
endforeach()
string(APPEND body "    };\n    return sources;\n}\n}  // namespace rayclass::clrt\n")
file(WRITE ${OUT}.tmp "${body}")
file(COPY_FILE ${OUT}.tmp ${OUT} ONLY_IF_DIFFERENT)
]=])
  add_custom_command(
    OUTPUT ${out}
    COMMAND ${CMAKE_COMMAND} -P ${script}
    DEPENDS ${ARGN} ${script}
    COMMENT "Embedding OpenCL kernels")
endfunction()

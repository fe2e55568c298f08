# kcrig_embed_page(PREFIX HTML JS TEMPLATE OUTPUT): compiles a page and its
# script into a header, so that the binary serves or writes the page
# without finding data files: reads HTML and JS into PREFIX_HTML and
# PREFIX_JS, configures TEMPLATE (which names them @PREFIX_HTML@,
# @PREFIX_JS@) into OUTPUT, and configures again when either changes.
function(kcrig_embed_page prefix html js template output)
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${html} ${js})
  file(READ ${html} ${prefix}_HTML)
  file(READ ${js} ${prefix}_JS)
  configure_file(${template} ${output} @ONLY)
endfunction()

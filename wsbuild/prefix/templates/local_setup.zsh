@HEADER@
# a zsh script is able to determine its own path if necessary
if [ -z "${COLCON_CURRENT_PREFIX:-}" ]; then
  _wsb_ls_prefix="${${(%):-%N}:a:h}"
else
  _wsb_ls_prefix="$COLCON_CURRENT_PREFIX"
fi

@FUNCTIONS@
@BODY@
unset -f _wsb_ls_prepend _wsb_ls_append _wsb_ls_prepend_checked _wsb_ls_append_checked _wsb_ls_filter _wsb_ls_source
unset _wsb_ls_prefix _wsb_ls_name _wsb_ls_old _wsb_ls_new _wsb_ls_value

# Writes a program's manual page from its --help text, so the page says what the program says.
# cmake -DPROGRAM=<executable> -DNAME=<name> -DSUMMARY=<one line> -DVERSION=<v> -DOUT=<page.1>
#       -P manpage.cmake
# (mocapctl prints its usage on stderr, mocapd on stdout: both are read.)
# The page is gzip -9n compressed beside OUT (OUT.gz), as Debian installs manual pages.
execute_process(COMMAND ${PROGRAM} --help OUTPUT_VARIABLE help ERROR_VARIABLE help
                RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "${PROGRAM} --help exited with ${status}")
endif()
# roff: a backslash is written \e; a line starting with . or ' would be a request.
string(REPLACE "\\" "\\e" help "${help}")
string(REGEX REPLACE "(^|\n)([.'])" "\\1\\\\&\\2" help "${help}")
string(REPLACE "-" "\\-" help "${help}")
file(WRITE ${OUT} ".TH ${NAME} 1 \"\" \"mocapd ${VERSION}\" \"mocapd\"
.SH NAME
${NAME} \\- ${SUMMARY}
.SH SYNOPSIS
The usage, as printed by
.B ${NAME} \\-\\-help:
.PP
.nf
${help}.fi
.SH SEE ALSO
/usr/share/mocapd/configs (example configurations), /etc/mocapd/mocapd.yaml (the service's).
")
execute_process(COMMAND gzip -9n -f ${OUT} COMMAND_ERROR_IS_FATAL ANY)

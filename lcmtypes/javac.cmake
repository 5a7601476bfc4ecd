# Compiles every generated .java file below SRC into OUT with CP on the class path.
file(GLOB_RECURSE sources ${SRC}/*.java)
execute_process(COMMAND ${JAVAC} -nowarn --release 8 -cp ${CP} -d ${OUT} ${sources}
  RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "javac failed on the generated LCM types")
endif()

!> The part of FFTW 3 that beadmob calls (fft_operator.F90, pruned_transform.f90,
!> kernel_spectrum.f90), declared here once.
module beadmob_fftw
  use, intrinsic :: iso_c_binding
  implicit none
  public

  ! The part of FFTW's Fortran 2003 (MPI) interface beadmob uses, with the names, C symbols and
  ! argument types of /usr/include/fftw3-mpi.f03 and fftw3.f03 (FFTW 3 ABI). That header is not
  ! included because gfortran's INCLUDE (and cpp) does not find its nested include 'fftw3.f03'
  ! without an -I for the FFTW include directory, which the build does not pass.
  integer(C_INT), parameter :: FFTW_MEASURE = 0, FFTW_ESTIMATE = 64, FFTW_WISDOM_ONLY = 2097152
  integer(C_INTPTR_T), parameter :: FFTW_MPI_DEFAULT_BLOCK = 0
  integer(C_INT), parameter :: FFTW_FORWARD = -1, FFTW_BACKWARD = 1

  !> One dimension of a guru plan: length, input and output stride (in elements).
  type, bind(C) :: fftw_iodim
    integer(C_INT) :: n, is, os
  end type fftw_iodim

  interface
    subroutine fftw_mpi_init() bind(C, name='fftw_mpi_init')
    end subroutine fftw_mpi_init
    integer(C_INTPTR_T) function fftw_mpi_local_size_many_transposed(rnk, n, howmany, block0, block1, comm, &
                                                                     local_n0, local_0_start, local_n1, local_1_start) &
      bind(C, name='fftw_mpi_local_size_many_transposed_f03')
      import :: C_INT, C_INTPTR_T, C_INT32_T
      integer(C_INT), value :: rnk
      integer(C_INTPTR_T), dimension(*), intent(in) :: n
      integer(C_INTPTR_T), value :: howmany, block0, block1
      integer(C_INT32_T), value :: comm
      integer(C_INTPTR_T), intent(out) :: local_n0, local_0_start, local_n1, local_1_start
    end function fftw_mpi_local_size_many_transposed
    integer(C_INT) function fftw_import_wisdom_from_filename(path) bind(C, name='fftw_import_wisdom_from_filename')
      import :: C_INT, C_CHAR
      character(kind=C_CHAR), dimension(*), intent(in) :: path
    end function fftw_import_wisdom_from_filename
    integer(C_INT) function fftw_export_wisdom_to_filename(path) bind(C, name='fftw_export_wisdom_to_filename')
      import :: C_INT, C_CHAR
      character(kind=C_CHAR), dimension(*), intent(in) :: path
    end function fftw_export_wisdom_to_filename
    subroutine fftw_mpi_broadcast_wisdom(comm) bind(C, name='fftw_mpi_broadcast_wisdom_f03')
      import :: C_INT32_T
      integer(C_INT32_T), value :: comm
    end subroutine fftw_mpi_broadcast_wisdom
    subroutine fftw_mpi_gather_wisdom(comm) bind(C, name='fftw_mpi_gather_wisdom_f03')
      import :: C_INT32_T
      integer(C_INT32_T), value :: comm
    end subroutine fftw_mpi_gather_wisdom
    subroutine fftw_destroy_plan(p) bind(C, name='fftw_destroy_plan')
      import :: C_PTR
      type(C_PTR), value :: p
    end subroutine fftw_destroy_plan
    type(C_PTR) function fftw_alloc_real(n) bind(C, name='fftw_alloc_real')
      import :: C_PTR, C_SIZE_T
      integer(C_SIZE_T), value :: n
    end function fftw_alloc_real
    subroutine fftw_free(p) bind(C, name='fftw_free')
      import :: C_PTR
      type(C_PTR), value :: p
    end subroutine fftw_free
    ! Serial guru plans and the MPI transpose of the pruned transforms (pruned_transform.f90);
    ! their arrays are passed as C pointers into the one aligned buffer.
    type(C_PTR) function fftw_plan_guru_dft_r2c(rank, dims, howmany_rank, howmany_dims, in, out, flags) &
      bind(C, name='fftw_plan_guru_dft_r2c')
      import :: C_PTR, C_INT, fftw_iodim
      integer(C_INT), value :: rank, howmany_rank, flags
      type(fftw_iodim), dimension(*), intent(in) :: dims, howmany_dims
      type(C_PTR), value :: in, out
    end function fftw_plan_guru_dft_r2c
    type(C_PTR) function fftw_plan_guru_dft_c2r(rank, dims, howmany_rank, howmany_dims, in, out, flags) &
      bind(C, name='fftw_plan_guru_dft_c2r')
      import :: C_PTR, C_INT, fftw_iodim
      integer(C_INT), value :: rank, howmany_rank, flags
      type(fftw_iodim), dimension(*), intent(in) :: dims, howmany_dims
      type(C_PTR), value :: in, out
    end function fftw_plan_guru_dft_c2r
    type(C_PTR) function fftw_plan_guru_dft(rank, dims, howmany_rank, howmany_dims, in, out, sign, flags) &
      bind(C, name='fftw_plan_guru_dft')
      import :: C_PTR, C_INT, fftw_iodim
      integer(C_INT), value :: rank, howmany_rank, sign, flags
      type(fftw_iodim), dimension(*), intent(in) :: dims, howmany_dims
      type(C_PTR), value :: in, out
    end function fftw_plan_guru_dft
    type(C_PTR) function fftw_mpi_plan_many_transpose(n0, n1, howmany, block0, block1, in, out, comm, flags) &
      bind(C, name='fftw_mpi_plan_many_transpose_f03')
      import :: C_PTR, C_INT, C_INTPTR_T, C_INT32_T
      integer(C_INTPTR_T), value :: n0, n1, howmany, block0, block1
      type(C_PTR), value :: in, out
      integer(C_INT32_T), value :: comm
      integer(C_INT), value :: flags
    end function fftw_mpi_plan_many_transpose
    !> Runs a plan on the arrays it was made for.
    subroutine fftw_execute(p) bind(C, name='fftw_execute')
      import :: C_PTR
      type(C_PTR), value :: p
    end subroutine fftw_execute
  end interface

contains

  !> The leading dimension of a scratch of slow-axis lines of n complex numbers, which the
  !> transforms fill and read across the lines (one number of each line in turn): odd, so that
  !> the numbers a line apart do not fall into the same few cache sets, as with a stride of a
  !> power of two (256 x 16 bytes maps every line to one set).
  pure integer function line_stride(n)
    integer, intent(in) :: n
    line_stride = n + 1 - mod(n, 2)
  end function line_stride
end module beadmob_fftw

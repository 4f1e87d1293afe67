!> Thin, checked layer over the HDF5 Fortran API for beadmob's files. Files are opened with
!> the MPI-IO driver on the run's communicator; every routine here is collective: all ranks
!> call it with the same arguments (replicated data), except the distributed writes, where
!> each rank passes its own block.
module beadmob_hdf5_support
  use, intrinsic :: iso_c_binding, only: c_ptr, c_loc
  use hdf5
  use mpi, only: MPI_INFO_NULL
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_parallel, only: run_context_t
  implicit none
  private
  public :: h5_create_parallel, h5_close_file, h5_create_group, h5_close_group
  public :: write_attribute, write_text_dataset, write_replicated_dataset, write_distributed_columns
  public :: read_text_attribute, read_int_attribute, read_real_attribute, set_hdf5_error_stack
  public :: h5_open_parallel_readonly, read_distributed_columns

  !> Longest text attribute read back (keys are a few thousand characters at most).
  integer, parameter :: max_text_length = 65536

  interface write_attribute
    module procedure write_attribute_text, write_attribute_int, write_attribute_int8, write_attribute_real, &
                     write_attribute_reals, write_attribute_ints
  end interface write_attribute

  interface write_replicated_dataset
    module procedure write_replicated_vector, write_replicated_matrix, write_replicated_array3
  end interface write_replicated_dataset

contains

  subroutine check(hdf_status, what, err)
    integer, intent(in) :: hdf_status
    character(len=*), intent(in) :: what
    type(error_t), intent(inout) :: err
    if (hdf_status < 0) call raise(err, 'HDF5 failed to ' // what)
  end subroutine check

  !> Create (truncate) `path` for collective writing on the run's communicator.
  subroutine h5_create_parallel(ctx, path, file_id, err)
    type(run_context_t), intent(in) :: ctx
    character(len=*), intent(in) :: path
    integer(hid_t), intent(out) :: file_id
    type(error_t), intent(inout) :: err
    integer(hid_t) :: access
    integer :: status
    call mpio_access(ctx, access, err)
    call h5fcreate_f(path, H5F_ACC_TRUNC_F, file_id, status, access_prp=access)
    call check(status, "create '" // path // "'", err)
    call h5pclose_f(access, status)
  end subroutine h5_create_parallel

  !> Open an existing `path` read-only for collective reading on the run's communicator.
  subroutine h5_open_parallel_readonly(ctx, path, file_id, err)
    type(run_context_t), intent(in) :: ctx
    character(len=*), intent(in) :: path
    integer(hid_t), intent(out) :: file_id
    type(error_t), intent(inout) :: err
    integer(hid_t) :: access
    integer :: status
    call mpio_access(ctx, access, err)
    call h5fopen_f(path, H5F_ACC_RDONLY_F, file_id, status, access_prp=access)
    if (status < 0) then
      file_id = -1
      call raise(err, 'not readable as an HDF5 file')
    end if
    call h5pclose_f(access, status)
  end subroutine h5_open_parallel_readonly

  !> HDF5 initialised and a file-access property list with the MPI-IO driver on the run's
  !> communicator (the caller closes it).
  subroutine mpio_access(ctx, access, err)
    type(run_context_t), intent(in) :: ctx
    integer(hid_t), intent(out) :: access
    type(error_t), intent(inout) :: err
    integer :: status
    call h5open_f(status)
    call check(status, 'initialise', err)
    call h5pcreate_f(H5P_FILE_ACCESS_F, access, status)
    call h5pset_fapl_mpio_f(access, ctx%comm, MPI_INFO_NULL, status)
    call check(status, 'set the MPI-IO file driver', err)
  end subroutine mpio_access

  subroutine h5_close_file(file_id, err)
    integer(hid_t), intent(in) :: file_id
    type(error_t), intent(inout) :: err
    integer :: status
    call h5fclose_f(file_id, status)
    call check(status, 'close the file', err)
  end subroutine h5_close_file

  subroutine h5_create_group(parent, name, group_id, err)
    integer(hid_t), intent(in) :: parent
    character(len=*), intent(in) :: name
    integer(hid_t), intent(out) :: group_id
    type(error_t), intent(inout) :: err
    integer :: status
    call h5gcreate_f(parent, name, group_id, status)
    call check(status, 'create group ' // name, err)
  end subroutine h5_create_group

  subroutine h5_close_group(group_id, err)
    integer(hid_t), intent(in) :: group_id
    type(error_t), intent(inout) :: err
    integer :: status
    call h5gclose_f(group_id, status)
    call check(status, 'close a group', err)
  end subroutine h5_close_group

  !> A fixed-length ASCII string type of the given length (h5py reads it as bytes).
  function text_type(length) result(type_id)
    integer, intent(in) :: length
    integer(hid_t) :: type_id
    integer :: status
    call h5tcopy_f(H5T_FORTRAN_S1, type_id, status)
    call h5tset_size_f(type_id, int(max(length, 1), size_t), status)
    call h5tset_strpad_f(type_id, H5T_STR_NULLTERM_F, status)
  end function text_type

  !> At least one character: an empty string is stored as a single NUL (read back as '').
  pure function null_padded(value) result(buffer)
    character(len=*), intent(in) :: value
    character(len=max(len(value), 1)) :: buffer
    buffer = achar(0)
    buffer(1:len(value)) = value
  end function null_padded

  subroutine write_attribute_text(location, name, value, err)
    integer(hid_t), intent(in) :: location
    character(len=*), intent(in) :: name, value
    type(error_t), intent(inout) :: err
    integer(hid_t) :: space, attribute, type_id
    integer :: status
    call h5screate_f(H5S_SCALAR_F, space, status)
    type_id = text_type(len(value))
    call h5acreate_f(location, name, type_id, space, attribute, status)
    call check(status, 'create attribute ' // name, err)
    call h5awrite_f(attribute, type_id, null_padded(value), [1_hsize_t], status)
    call check(status, 'write attribute ' // name, err)
    call h5aclose_f(attribute, status)
    call h5tclose_f(type_id, status)
    call h5sclose_f(space, status)
  end subroutine write_attribute_text

  subroutine write_attribute_int(location, name, value, err)
    integer(hid_t), intent(in) :: location
    character(len=*), intent(in) :: name
    integer, intent(in) :: value
    type(error_t), intent(inout) :: err
    call write_attribute_int8(location, name, int(value, i8), err)
  end subroutine write_attribute_int

  subroutine write_attribute_int8(location, name, value, err)
    integer(hid_t), intent(in) :: location
    character(len=*), intent(in) :: name
    integer(i8), intent(in) :: value
    type(error_t), intent(inout) :: err
    integer(i8), target :: buffer(1)
    buffer = value
    call write_numeric_attribute(location, name, H5T_STD_I64LE, h5kind_to_type(i8, H5_INTEGER_KIND), .true., 1, &
                                 c_loc(buffer), err)
  end subroutine write_attribute_int8

  subroutine write_attribute_real(location, name, value, err)
    integer(hid_t), intent(in) :: location
    character(len=*), intent(in) :: name
    real(dp), intent(in) :: value
    type(error_t), intent(inout) :: err
    real(dp), target :: buffer(1)
    buffer = value
    call write_numeric_attribute(location, name, H5T_NATIVE_DOUBLE, H5T_NATIVE_DOUBLE, .true., 1, c_loc(buffer), err)
  end subroutine write_attribute_real

  subroutine write_attribute_reals(location, name, values, err)
    integer(hid_t), intent(in) :: location
    character(len=*), intent(in) :: name
    real(dp), intent(in) :: values(:)
    type(error_t), intent(inout) :: err
    real(dp), target :: buffer(size(values))
    buffer = values
    call write_numeric_attribute(location, name, H5T_NATIVE_DOUBLE, H5T_NATIVE_DOUBLE, .false., size(values), &
                                 c_loc(buffer), err)
  end subroutine write_attribute_reals

  subroutine write_attribute_ints(location, name, values, err)
    integer(hid_t), intent(in) :: location
    character(len=*), intent(in) :: name
    integer, intent(in) :: values(:)
    type(error_t), intent(inout) :: err
    integer, target :: buffer(size(values))
    buffer = values
    call write_numeric_attribute(location, name, H5T_NATIVE_INTEGER, H5T_NATIVE_INTEGER, .false., size(values), &
                                 c_loc(buffer), err)
  end subroutine write_attribute_ints

  !> The one numeric attribute writer: a scalar or a 1-D array of `n` values at `buffer`.
  subroutine write_numeric_attribute(location, name, file_type, memory_type, scalar, n, buffer, err)
    integer(hid_t), intent(in) :: location, file_type, memory_type
    character(len=*), intent(in) :: name
    logical, intent(in) :: scalar
    integer, intent(in) :: n
    type(c_ptr), intent(in) :: buffer
    type(error_t), intent(inout) :: err
    integer(hid_t) :: space, attribute
    integer :: status
    if (scalar) then
      call h5screate_f(H5S_SCALAR_F, space, status)
    else
      call h5screate_simple_f(1, [int(n, hsize_t)], space, status)
    end if
    call h5acreate_f(location, name, file_type, space, attribute, status)
    call check(status, 'create attribute ' // name, err)
    call h5awrite_f(attribute, memory_type, buffer, status)
    call check(status, 'write attribute ' // name, err)
    call h5aclose_f(attribute, status)
    call h5sclose_f(space, status)
  end subroutine write_numeric_attribute

  !> Scalar string dataset, written by rank 0 within a collective call.
  subroutine write_text_dataset(ctx, location, name, value, err)
    type(run_context_t), intent(in) :: ctx
    integer(hid_t), intent(in) :: location
    character(len=*), intent(in) :: name, value
    type(error_t), intent(inout) :: err
    integer(hid_t) :: space, dataset, type_id
    integer :: status
    call h5screate_f(H5S_SCALAR_F, space, status)
    type_id = text_type(len(value))
    call h5dcreate_f(location, name, type_id, space, dataset, status)
    call check(status, 'create dataset ' // name, err)
    if (ctx%rank /= 0) call h5sselect_none_f(space, status)
    call h5dwrite_f(dataset, type_id, null_padded(value), [1_hsize_t], status, mem_space_id=space, &
                    file_space_id=space)
    call check(status, 'write dataset ' // name, err)
    call h5dclose_f(dataset, status)
    call h5tclose_f(type_id, status)
    call h5sclose_f(space, status)
  end subroutine write_text_dataset

  subroutine write_replicated_vector(ctx, location, name, values, err)
    type(run_context_t), intent(in) :: ctx
    integer(hid_t), intent(in) :: location
    character(len=*), intent(in) :: name
    real(dp), intent(in) :: values(:)
    type(error_t), intent(inout) :: err
    call write_replicated(ctx, location, name, values, [int(size(values), hsize_t)], err)
  end subroutine write_replicated_vector

  !> A Fortran (m, n) array appears as (n, m) to C readers such as h5py.
  subroutine write_replicated_matrix(ctx, location, name, values, err)
    type(run_context_t), intent(in) :: ctx
    integer(hid_t), intent(in) :: location
    character(len=*), intent(in) :: name
    real(dp), intent(in) :: values(:, :)
    type(error_t), intent(inout) :: err
    call write_replicated(ctx, location, name, values, int(shape(values), hsize_t), err)
  end subroutine write_replicated_matrix

  subroutine write_replicated_array3(ctx, location, name, values, err)
    type(run_context_t), intent(in) :: ctx
    integer(hid_t), intent(in) :: location
    character(len=*), intent(in) :: name
    real(dp), intent(in) :: values(:, :, :)
    type(error_t), intent(inout) :: err
    call write_replicated(ctx, location, name, values, int(shape(values), hsize_t), err)
  end subroutine write_replicated_array3

  !> Small data every rank holds: rank 0 writes it, the others select nothing.
  subroutine write_replicated(ctx, location, name, values, dims, err)
    type(run_context_t), intent(in) :: ctx
    integer(hid_t), intent(in) :: location
    character(len=*), intent(in) :: name
    real(dp), intent(in) :: values(*)
    integer(hsize_t), intent(in) :: dims(:)
    type(error_t), intent(inout) :: err
    integer(hid_t) :: space, dataset
    integer :: status
    call h5screate_simple_f(size(dims), dims, space, status)
    call h5dcreate_f(location, name, H5T_NATIVE_DOUBLE, space, dataset, status)
    call check(status, 'create dataset ' // name, err)
    if (ctx%rank /= 0) call h5sselect_none_f(space, status)
    call h5dwrite_f(dataset, H5T_NATIVE_DOUBLE, values(1:product(dims)), dims, status, &
                    mem_space_id=space, file_space_id=space)
    call check(status, 'write dataset ' // name, err)
    call h5dclose_f(dataset, status)
    call h5sclose_f(space, status)
  end subroutine write_replicated

  !> A (rows, n_total) array distributed by columns: this rank holds columns
  !> first..first+size(block,2)-1. Written with one collective MPI-IO transfer.
  subroutine write_distributed_columns(location, name, block, first, n_total, err)
    integer(hid_t), intent(in) :: location
    character(len=*), intent(in) :: name
    real(dp), intent(in) :: block(:, :)
    integer(i8), intent(in) :: first, n_total
    type(error_t), intent(inout) :: err
    integer(hid_t) :: file_space, memory_space, dataset, transfer
    integer(hsize_t) :: file_dims(2), block_dims(2)
    integer :: status
    file_dims = [int(size(block, 1), hsize_t), int(n_total, hsize_t)]
    block_dims = [int(size(block, 1), hsize_t), int(size(block, 2), hsize_t)]
    call h5screate_simple_f(2, file_dims, file_space, status)
    call h5dcreate_f(location, name, H5T_NATIVE_DOUBLE, file_space, dataset, status)
    call check(status, 'create dataset ' // name, err)
    call select_columns(file_space, block_dims, first, memory_space, transfer, status)
    call check(status, 'select the block of ' // name // ' starting at column ' // str(first), err)
    call h5dwrite_f(dataset, H5T_NATIVE_DOUBLE, block, block_dims, status, &
                    mem_space_id=memory_space, file_space_id=file_space, xfer_prp=transfer)
    call check(status, 'write dataset ' // name, err)
    call h5pclose_f(transfer, status)
    call h5sclose_f(memory_space, status)
    call h5dclose_f(dataset, status)
    call h5sclose_f(file_space, status)
  end subroutine write_distributed_columns

  !> The counterpart of write_distributed_columns: this rank reads columns
  !> first..first+size(block,2)-1 of the (size(block,1), n_total) dataset `name`, in one collective
  !> MPI-IO transfer. A dataset of another shape raises `err` (nothing read).
  subroutine read_distributed_columns(location, name, block, first, n_total, err)
    integer(hid_t), intent(in) :: location
    character(len=*), intent(in) :: name
    real(dp), intent(inout) :: block(:, :)
    integer(i8), intent(in) :: first, n_total
    type(error_t), intent(inout) :: err
    integer(hid_t) :: file_space, memory_space, dataset, transfer
    integer(hsize_t) :: file_dims(2), max_dims(2), block_dims(2)
    integer :: status, rank
    call h5dopen_f(location, name, dataset, status)
    if (status < 0) then
      call raise(err, 'cannot open dataset ' // name)
      return
    end if
    call h5dget_space_f(dataset, file_space, status)
    call h5sget_simple_extent_ndims_f(file_space, rank, status)
    file_dims = 0
    if (rank == 2) call h5sget_simple_extent_dims_f(file_space, file_dims, max_dims, status)
    if (rank /= 2 .or. file_dims(1) /= int(size(block, 1), hsize_t) .or. file_dims(2) /= int(n_total, hsize_t)) then
      call raise(err, 'dataset ' // name // ' has an unexpected shape')
      call h5sclose_f(file_space, status)
      call h5dclose_f(dataset, status)
      return
    end if
    block_dims = [int(size(block, 1), hsize_t), int(size(block, 2), hsize_t)]
    call select_columns(file_space, block_dims, first, memory_space, transfer, status)
    call h5dread_f(dataset, H5T_NATIVE_DOUBLE, block, block_dims, status, &
                   mem_space_id=memory_space, file_space_id=file_space, xfer_prp=transfer)
    call check(status, 'read dataset ' // name // ' (damaged file?)', err)
    call h5pclose_f(transfer, status)
    call h5sclose_f(memory_space, status)
    call h5sclose_f(file_space, status)
    call h5dclose_f(dataset, status)
  end subroutine read_distributed_columns

  !> This rank's columns first..first+block_dims(2)-1 selected in file_space (none for an empty
  !> block: the transfer is collective, every rank takes part), the matching memory space, and a
  !> collective MPI-IO transfer list; the caller closes memory_space and transfer.
  subroutine select_columns(file_space, block_dims, first, memory_space, transfer, status)
    integer(hid_t), intent(in) :: file_space
    integer(hsize_t), intent(in) :: block_dims(2)
    integer(i8), intent(in) :: first
    integer(hid_t), intent(out) :: memory_space, transfer
    integer, intent(out) :: status
    integer :: ignored
    call h5screate_simple_f(2, block_dims, memory_space, ignored)
    if (block_dims(2) > 0) then
      call h5sselect_hyperslab_f(file_space, H5S_SELECT_SET_F, [0_hsize_t, int(first - 1, hsize_t)], block_dims, status)
    else
      call h5sselect_none_f(file_space, status)
      call h5sselect_none_f(memory_space, ignored)
    end if
    call h5pcreate_f(H5P_DATASET_XFER_F, transfer, ignored)
    call h5pset_dxpl_mpio_f(transfer, H5FD_MPIO_COLLECTIVE_F, ignored)
  end subroutine select_columns

  !> HDF5 prints its error stack (tens of lines) on every failed call by default. beadmob reports
  !> each failure in one line of its own instead (a damaged cache or checkpoint is even an
  !> expected case), so the driver turns the stack off for the whole run; -hdf5_error_stack keeps
  !> it, for debugging.
  subroutine set_hdf5_error_stack(shown)
    logical, intent(in) :: shown
    integer :: status
    call h5open_f(status)
    call h5eset_auto_f(merge(1, 0, shown), status)
  end subroutine set_hdf5_error_stack

  subroutine read_text_attribute(location, name, value, err)
    integer(hid_t), intent(in) :: location
    character(len=*), intent(in) :: name
    character(len=:), allocatable, intent(out) :: value
    type(error_t), intent(inout) :: err
    integer(hid_t) :: attribute, file_type, memory_type
    integer(size_t) :: length
    integer :: status, class, nul
    character(len=:), allocatable :: buffer
    value = ''
    call h5aopen_f(location, name, attribute, status)
    if (status < 0) then
      call raise(err, 'no attribute ' // name)
      return
    end if
    call h5aget_type_f(attribute, file_type, status)
    call h5tget_class_f(file_type, class, status)
    call h5tget_size_f(file_type, length, status)
    call h5tclose_f(file_type, status)
    if (class /= H5T_STRING_F .or. length < 1 .or. length > max_text_length) then
      call raise(err, 'attribute ' // name // ' is not a text')
      call h5aclose_f(attribute, status)
      return
    end if
    call h5tcopy_f(H5T_FORTRAN_S1, memory_type, status)
    call h5tset_size_f(memory_type, length, status)
    allocate (character(len=length) :: buffer)
    call h5aread_f(attribute, memory_type, buffer, [1_hsize_t], status)
    call check(status, 'read attribute ' // name, err)
    call h5tclose_f(memory_type, status)
    call h5aclose_f(attribute, status)
    nul = index(buffer, achar(0))
    if (nul > 0) buffer = buffer(1:nul - 1)
    value = trim(buffer)
  end subroutine read_text_attribute

  subroutine read_int_attribute(location, name, value, err)
    integer(hid_t), intent(in) :: location
    character(len=*), intent(in) :: name
    integer, intent(out) :: value
    type(error_t), intent(inout) :: err
    integer(hid_t) :: attribute
    integer :: status
    value = 0
    call h5aopen_f(location, name, attribute, status)
    if (status < 0) then
      call raise(err, 'no attribute ' // name)
      return
    end if
    call h5aread_f(attribute, H5T_NATIVE_INTEGER, value, [1_hsize_t], status)
    call check(status, 'read attribute ' // name, err)
    call h5aclose_f(attribute, status)
  end subroutine read_int_attribute

  subroutine read_real_attribute(location, name, value, err)
    integer(hid_t), intent(in) :: location
    character(len=*), intent(in) :: name
    real(dp), intent(out) :: value
    type(error_t), intent(inout) :: err
    integer(hid_t) :: attribute
    integer :: status
    value = 0.0_dp
    call h5aopen_f(location, name, attribute, status)
    if (status < 0) then
      call raise(err, 'no attribute ' // name)
      return
    end if
    call h5aread_f(attribute, H5T_NATIVE_DOUBLE, value, [1_hsize_t], status)
    call check(status, 'read attribute ' // name, err)
    call h5aclose_f(attribute, status)
  end subroutine read_real_attribute
end module beadmob_hdf5_support

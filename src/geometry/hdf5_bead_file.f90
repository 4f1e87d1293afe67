!> HDF5 bead files: a float64 dataset of bead centres that C/Python readers see as (N, 3)
!> (Fortran: (3, N)); by default '/geometry/positions', so a beadmob result file is also a
!> bead file. Read by one rank (the caller broadcasts).
module beadmob_hdf5_bead_file
  use hdf5
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  implicit none
  private
  public :: read_hdf5_bead_file, is_hdf5_file

contains

  logical function is_hdf5_file(path)
    character(len=*), intent(in) :: path
    integer :: status
    logical :: exists
    is_hdf5_file = .false.
    inquire (file=path, exist=exists)
    if (.not. exists) return
    call h5open_f(status)
    call h5fis_hdf5_f(path, is_hdf5_file, status)
    if (status < 0) is_hdf5_file = .false.
  end function is_hdf5_file

  subroutine read_hdf5_bead_file(path, dataset_path, centres, err)
    character(len=*), intent(in) :: path, dataset_path
    real(dp), allocatable, intent(out) :: centres(:, :)
    type(error_t), intent(inout) :: err
    integer(hid_t) :: file_id, dataset, space, data_type
    integer(hsize_t) :: dims(2), max_dims(2)
    integer :: status, rank
    integer(hid_t), parameter :: no_id = -1
    logical :: exists
    integer :: type_class

    allocate (centres(3, 0))
    call h5open_f(status)
    call h5eset_auto_f(0, status)   ! our own messages replace the HDF5 error stack dump
    call h5fopen_f(path, H5F_ACC_RDONLY_F, file_id, status)
    if (status < 0) then
      call raise(err, "cannot open HDF5 bead file '" // path // "'")
      return
    end if
    dataset = no_id
    call h5lexists_f(file_id, dataset_path, exists, status)
    if (status < 0 .or. .not. exists) then
      call raise(err, path // ": no dataset '" // dataset_path // "' (set &shape dataset to the bead centres)")
    else
      call h5dopen_f(file_id, dataset_path, dataset, status)
      call h5dget_type_f(dataset, data_type, status)
      call h5tget_class_f(data_type, type_class, status)
      call h5tclose_f(data_type, status)
      call h5dget_space_f(dataset, space, status)
      call h5sget_simple_extent_ndims_f(space, rank, status)
      if (rank == 2) call h5sget_simple_extent_dims_f(space, dims, max_dims, status)
      call h5sclose_f(space, status)
      if (type_class /= H5T_FLOAT_F) then
        call raise(err, path // ': dataset ' // dataset_path // ' is not floating point')
      else if (rank /= 2) then
        call raise(err, path // ': dataset ' // dataset_path // ' must be 2-D (N, 3), it has rank ' // str(rank))
      else if (dims(1) /= 3) then
        call raise(err, path // ': dataset ' // dataset_path // ' must have shape (N, 3), found (' // &
                   str(int(dims(2))) // ', ' // str(int(dims(1))) // ')')
      else
        deallocate (centres)
        allocate (centres(3, dims(2)))
        call h5dread_f(dataset, H5T_NATIVE_DOUBLE, centres, dims, status)
        if (status < 0) call raise(err, path // ': cannot read dataset ' // dataset_path)
      end if
      call h5dclose_f(dataset, status)
    end if
    call h5fclose_f(file_id, status)
  end subroutine read_hdf5_bead_file
end module beadmob_hdf5_bead_file
